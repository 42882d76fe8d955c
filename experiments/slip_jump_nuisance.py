"""The slip-jump test with its nuisance parameters re-optimised at ``J = 0``.

Stiction and dead band are nested (the dead band is the stick-slip valve at ``J = 0``,
the play operator), and ``diagnose`` decides between them by the profile likelihood
ratio of ``J = 0`` from the closed-loop valve identification
(``hammerstein._profile``). ``slip_jump_calibration.md`` shows that test rejecting
``J = 0`` on true dead bands several times as often as alpha. One cause is in the test
itself: at ``J = 0`` the profile held the process (``τ``, and the dead-time shift of a
given model) at the stick-slip valve's estimate and scanned ``S`` around the fitted ``S``
only, while the unrestricted fit had searched all of them. A valve ``(S, J)`` moving lags
OP by ``(S − J)/2``, so the dead band it resembles is about ``S − J`` wide, which the scan
(0.7 S … 1.45 S) missed whenever ``J > 0.3 S``. A restricted fit searched less hard than
the unrestricted one inflates the likelihood ratio. The candidate
(``hammerstein.J0_NUISANCE``, :func:`hammerstein._dead_band_fit`) refits the dead
band with the band's width from ``(S − J)/2`` to ``1.45 S`` and the process nuisance
re-chosen (the held shifts of a given model; ``τ`` and ``θ`` by Nelder–Mead without a
model, at ff610a6), and takes the better of the two restricted fits.

**The criterion, fixed before the scoring run** (recorded in the commit that adds this
script, before blocks 27000–30000 were diagnosed with the candidate): the candidate
replaces the shipped test iff, on the holdout family's blind blocks 27000, 28000, 29000
and 30000 (12 seeds per class and level each; never used to choose anything), the dead-band
and stiction recordings named correctly (dead band named ``deadband`` plus stiction named
``stiction``) are at least as many as shipped **at each level** and more in total. The
J test only decides between the two valve hypotheses once one of them is the pick
(``evidence.select``), so no other class's verdict and no ``none`` recording's verdict can
change; these two classes are all that can move.

Part C, added after the criterion was met on part B and before adoption was final: the
same comparison on the three tuning families (``concealed.py``'s generators and seeds,
a model given), the other dataset the project's rule asks every change to be reported on.
There the refit turned true sticky valves into dead bands (the refitted dead band beat
the stick-slip fit's own optimum, so the statistic fell to 0), as it had on ISDB CHEM23
without a model. The criterion as stated looked at one family only; with part C the
candidate is **not adopted** (``hammerstein.J0_NUISANCE`` stays False), and the report
says so.

Part A (mechanism, seen blocks 16000–19000, the recordings of
``slip_jump_calibration.md``'s rule variation) reports the test's size on true dead bands
and its power on sticky valves both ways. Part B is the score.

Run: ``.venv/bin/python experiments/slip_jump_nuisance.py [--jobs 2]`` (about 8 min on
2 cores). Outputs ``reports/concealed/slip_jump_nuisance.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
VALVES = ("deadband", "stiction")
SEEDS_PER_BLOCK = 12
#: Part A: seen blocks (a mechanism check); Part B: blind blocks (the score)
PARTS = {"A": (16000, 17000, 18000, 19000), "B": (27000, 28000, 29000, 30000), "C": (0,)}
#: part C's seeds per family, class and level (``make concealed``'s)
FAMILY_SEEDS = 4
VARIANTS = {"shipped": False, "nuisance": True}
ALPHA = 0.05


def case(cls: str, level: int, seed: int, variant: str, part: str) -> dict:
    """One recording diagnosed with its model, the ``J = 0`` end of the slip-jump test as
    ``variant`` (:data:`VARIANTS`): the holdout family's (parts A, B) or, in part C, a
    tuning family's (``seed`` = family index × 100 + seed)."""
    import concealed
    from slip_jump_symmetric import diagnose_flagged, slip_fields

    family = concealed.FAMILIES[seed // 100] if part == "C" else "holdout"
    job, d = diagnose_flagged(family, cls, level, seed % 100 if part == "C" else seed,
                              {"J0_NUISANCE": VARIANTS[variant]})
    f = slip_fields(d)
    return {"part": part, "class": cls, "level": level, "seed": seed, "variant": variant,
            "valve_model": family if part == "C" else job["valve_model"],
            **{k: f[k] for k in ("stop_rule", "S", "J", "slip_jump_stat", "slip_jump_p",
                                 "pick")}}


def table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (part, variant, cls, lvl), g in df.groupby(["part", "variant", "class", "level"],
                                                   sort=False):
        other = "stiction" if cls == "deadband" else "deadband"
        rows.append({"part": part, "J = 0 end": variant, "valve (truth)": cls, "level": lvl,
                     f"p < {ALPHA:g}": rate_text(int((g.slip_jump_p < ALPHA).sum()), len(g)),
                     "named right": rate_text(int((g.pick == cls).sum()), len(g)),
                     "named the other valve": rate_text(int((g.pick == other).sum()), len(g))})
    return pd.DataFrame(rows)


def verdict(df: pd.DataFrame) -> tuple[bool, list[str]]:
    """The criterion of the module docstring on part B."""
    b = df[df.part == "B"]
    right = {(v, lvl): int((g.pick == g["class"]).sum())
             for (v, lvl), g in b.groupby(["variant", "level"])}
    levels = sorted({lvl for _, lvl in right})
    each = all(right[("nuisance", lvl)] >= right[("shipped", lvl)] for lvl in levels)
    tot = {v: sum(right[(v, lvl)] for lvl in levels) for v in VARIANTS}
    ok = each and tot["nuisance"] > tot["shipped"]
    n = {lvl: int(((b.variant == "shipped") & (b.level == lvl)).sum()) for lvl in levels}
    lines = [f"- level {lvl}: named right {right[('shipped', lvl)]}/{n[lvl]} shipped, "
             f"{right[('nuisance', lvl)]}/{n[lvl]} with the nuisance re-optimised;"
             for lvl in levels]
    lines.append(f"- total {tot['shipped']} against {tot['nuisance']}: criterion "
                 + ("**met**." if ok else "**not met**: the shipped test stays."))
    return ok, lines


def report(df: pd.DataFrame) -> str:
    ok, lines = verdict(df)
    paired = df.pivot_table(index=["part", "class", "level", "seed"], columns="variant",
                            values="slip_jump_stat", aggfunc="first").dropna()
    lower = int((paired["nuisance"] < paired["shipped"] - 1e-9).sum())
    changed = df.pivot_table(index=["part", "class", "level", "seed"], columns="variant",
                             values="pick", aggfunc="first").dropna()
    moved = changed[changed["shipped"] != changed["nuisance"]]
    return "\n".join([
        "# The slip-jump test with its nuisance parameters re-optimised at J = 0",
        "",
        "Generated by `experiments/slip_jump_nuisance.py` (the question, the candidate and "
        "the criterion fixed before the scoring run are in its docstring). The holdout "
        "family's dead-band and stiction recordings, diagnosed with the model given, "
        f"{SEEDS_PER_BLOCK} seeds per class and level in each block; part A: seen blocks "
        f"{', '.join(map(str, PARTS['A']))} (mechanism); part B: blind blocks "
        f"{', '.join(map(str, PARTS['B']))} (the score). Wilson 95 % intervals.",
        "",
        to_markdown(table(df)),
        "",
        f"- the statistic of J = 0 is lower with the nuisance re-optimised on {lower} of "
        f"{len(paired)} recordings (it is never higher: the better of the two restricted "
        f"fits is taken); verdicts that moved: {len(moved)}"
        + (" (" + "; ".join(f"{c} L{lvl} {s} part {p}: {r.shipped} → {r.nuisance}"
                            for (p, c, lvl, s), r in moved.iterrows()) + ")"
           if len(moved) else "") + ".",
        "",
        "## The criterion (part B)",
        "",
        *lines,
        "",
        *part_c(df, ok),
        ""])


def lower_count(g: pd.DataFrame) -> int:
    """Recordings whose J = 0 statistic the refit lowered."""
    t = g.pivot_table(index=["class", "level", "seed"], columns="variant",
                      values="slip_jump_stat", aggfunc="first").dropna()
    return int((t["nuisance"] < t["shipped"] - 1e-9).sum())


def part_c(df: pd.DataFrame, met: bool) -> list[str]:
    """The tuning families (part C): named right both ways per class and level, the
    verdicts that moved, and the decision."""
    c = df[df.part == "C"]
    if c.empty:
        return ["(part C not run)"]
    right = {k: int((g.pick == g["class"]).sum())
             for k, g in c.groupby(["variant", "class", "level"])}
    n = {k[1:]: len(g) for k, g in c.groupby(["variant", "class", "level"])}
    rows = "; ".join(f"{cls} L{lvl} {right[('shipped', cls, lvl)]}/{n[(cls, lvl)]} → "
                     f"{right[('nuisance', cls, lvl)]}/{n[(cls, lvl)]}"
                     for cls, lvl in sorted(n))
    tot = {v: sum(x for k, x in right.items() if k[0] == v) for v in VARIANTS}
    piv = c.pivot_table(index=["valve_model", "class", "level", "seed"], columns="variant",
                        values=["pick", "slip_jump_stat"], aggfunc="first")
    moved = piv[piv[("pick", "shipped")] != piv[("pick", "nuisance")]]
    adopt = met and tot["nuisance"] >= tot["shipped"]
    b = df[df.part == "B"]
    return [
        "## The tuning families (part C: the other dataset)",
        "",
        f"`concealed.py`'s three generator families, {FAMILY_SEEDS} seeds per family, "
        "class and level, a model given (named right, shipped → nuisance re-optimised): "
        f"{rows}; total {tot['shipped']} → {tot['nuisance']}. Verdicts that moved: "
        + ("; ".join(f"{fam} {cls} L{lvl} {s % 100}: {r[('pick', 'shipped')]} → "
                     f"{r[('pick', 'nuisance')]} (statistic "
                     f"{r[('slip_jump_stat', 'shipped')]:.3g} → "
                     f"{r[('slip_jump_stat', 'nuisance')]:.3g})"
                     for (fam, cls, lvl, s), r in moved.iterrows()) or "none") + ".",
        "",
        "**Decision: " + ("adopted" if adopt else "not adopted") + "** (criterion on part "
        f"B {'met' if met else 'not met'}; part C {tot['shipped']} → {tot['nuisance']}).",
        "",
        "Reading: the restricted fit was searched too narrowly on most recordings (the "
        f"statistic falls on {lower_count(b)}/{len(b) // 2} of part B), but by little: "
        "true level-2 dead bands reject J = 0 "
        f"in {size(df, 'shipped')} as shipped and {size(df, 'nuisance')} with the "
        "refit (parts A and B), far above alpha. Where a verdict moved on a sticky valve, "
        "the refitted dead band fitted better than the stick-slip fit itself (statistic "
        "0): a dead band is the stick-slip valve at J = 0, so the unrestricted fit had "
        "stopped at a worse local optimum, and a refit of one end only turns that search "
        "failure into \"no slip jump\" (as on ISDB CHEM23 without a model). A test of "
        "J = 0 needs both ends searched with the same effort (the unrestricted fit "
        "restarted from the restricted optimum); the calibration lead stays open, with "
        "the stop rule chosen among non-nested ones (`slip_jump_calibration.md`) and a "
        "rugged criterion whose minimum over J behaves like the best of many looks as "
        "candidate causes.",
    ]


def size(df: pd.DataFrame, variant: str) -> str:
    """Level-2 true dead bands rejecting J = 0 at :data:`ALPHA`, parts A and B."""
    g = df[(df.variant == variant) & (df["class"] == "deadband") & (df.level == 2)
           & df.part.isin(["A", "B"])]
    return rate_text(int((g.slip_jump_p < ALPHA).sum()), len(g))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--parts", default="ABC", help="which parts to run (any of A, B, C)")
    ap.add_argument("--append", action="store_true",
                    help="keep the other parts' rows of slip_jump_nuisance.csv")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite the report from slip_jump_nuisance.csv without diagnosing")
    a = ap.parse_args(argv)
    if a.report_only:
        text = report(pd.read_csv(OUT / "slip_jump_nuisance.csv"))
        write_text(OUT / "slip_jump_nuisance.md", text)
        print(text)
        return 0
    # the tasks by reference to this module imported by name (see band_magnitude.py)
    import concealed
    import slip_jump_nuisance as me
    from joblib import Parallel, delayed
    from tqdm import tqdm

    def seeds(part: str) -> list[int]:
        if part == "C":
            return [100 * f + s for f in range(len(concealed.FAMILIES))
                    for s in range(FAMILY_SEEDS)]
        return [s for b in PARTS[part] for s in range(b, b + SEEDS_PER_BLOCK)]

    todo = [delayed(me.case)(c, lvl, s, v, part) for part in a.parts for v in VARIANTS
            for c in VALVES for lvl in (1, 2) for s in seeds(part)]
    df = pd.DataFrame(list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(todo),
                                total=len(todo), desc="slip-jump test")))
    if a.append:  # parts run before, kept: the new parts replace only their own rows
        old = pd.read_csv(OUT / "slip_jump_nuisance.csv")
        df = pd.concat([old[~old.part.isin(list(a.parts))], df], ignore_index=True)
    with atomic_path(OUT / "slip_jump_nuisance.csv") as tmp:
        df.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")
    text = report(df) if "B" in set(df.part) else to_markdown(table(df))
    if "B" in set(df.part):
        write_text(OUT / "slip_jump_nuisance.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
