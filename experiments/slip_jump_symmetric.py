"""Both ends of the slip-jump test searched with the same effort.

``slip_jump_nuisance.md`` refitted only the ``J = 0`` end of the test (the dead band,
its width searched from ``(S − J)/2`` and its dead-time shift re-chosen) and found the
refitted dead band fitting better than the stick-slip fit's own optimum on 3 of the 24
sticky valves of the tuning families: a dead band is the stick-slip valve at ``J = 0``,
so the unrestricted search had stopped at a worse local optimum, and a one-sided refit
read that search failure as "no slip jump". The candidate here
(``hammerstein.J0_RESTART`` with ``J0_NUISANCE``, a model given): refit the dead band,
restart the stick-slip valve from that dead band under every stop rule (``J = 0.2 S``,
Nelder–Mead as in the search), keep the best of all as the valve — a dead band when no
stick-slip fit beats it — and test ``J = 0`` against that optimum. It changes the fitted
valve, so the stiction hypothesis's parameters, and with them any class's verdict.

**The criterion, fixed before the scoring run** (in the commit that adds this script,
before any of its blocks was diagnosed): adopt iff

1. on the holdout family's blind blocks 31000, 32000, 33000, 34000 (never drawn before;
   every class, 12 seeds per class and level, 24 for ``none``), the recordings named
   right are at least as many as shipped at each level and more in total, and ``none``
   recordings called physics are not more at either level; and
2. on the three tuning families (``concealed.py``'s generators and seeds, every class,
   a model given), the recordings named right are at least as many as shipped at each
   level.

Run: ``.venv/bin/python experiments/slip_jump_symmetric.py [--jobs 2]`` (about 20 min on
2 cores). Outputs ``reports/concealed/slip_jump_symmetric.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_text, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
BLOCKS = (31000, 32000, 33000, 34000)
SEEDS, NONE_SEEDS, FAMILY_SEEDS, FAMILY_NONE_SEEDS = 12, 24, 4, 12
#: variant → (J0_NUISANCE, J0_RESTART)
VARIANTS = {"shipped": (False, False), "symmetric": (True, True)}
ALPHA = 0.05


def diagnose_flagged(family: str, cls: str, level: int, seed: int,
                     flags: dict[str, bool]) -> tuple[dict, object]:
    """One recording (the holdout family's, or a tuning family's by name) diagnosed with its
    model, :mod:`stictionbench.diagnosis.hammerstein`'s candidate ``flags`` set for the call
    and restored after it (a worker keeps the module state of its previous task).
    Returns ``(job, diagnosis)``."""
    import concealed
    import holdout_family as hf

    from stictionbench.diagnosis import diagnose, hammerstein, load_model
    from stictionbench.io import read_recording

    saved = {k: getattr(hammerstein, k) for k in flags}
    for k, v in flags.items():
        setattr(hammerstein, k, v)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            job = (hf.generate(cls, level, seed, Path(tmp)) if family == "holdout" else
                   concealed.generate(cls, level, seed, Path(tmp), family))
            d = diagnose(read_recording(job["csv"]), load_model(job["model"]))
    finally:
        for k, v in saved.items():
            setattr(hammerstein, k, v)
    return job, d


def slip_fields(d) -> dict:
    """The fitted valve and the test of ``J = 0`` of a diagnosis, and its verdict."""
    h = d.details.get("hammerstein") or {}
    t = d.tests.get("slip_jump_zero", {})
    return {"S": h.get("S"), "J": h.get("J"), "stop_rule": h.get("stop_rule"),
            "slip_jump_stat": t.get("statistic"), "slip_jump_p": t.get("p_value"),
            "pick": d.missing_physics}


def case(family: str, cls: str, level: int, seed: int, variant: str) -> dict:
    """One recording diagnosed with its model under ``variant``'s flags."""
    nuisance, restart = VARIANTS[variant]
    _, d = diagnose_flagged(family, cls, level, seed,
                            {"J0_NUISANCE": nuisance, "J0_RESTART": restart})
    return {"family": family, "class": cls, "level": level, "seed": seed, "variant": variant,
            **slip_fields(d)}


def tasks() -> list[tuple]:
    import concealed
    import holdout_family as hf

    out = [("holdout", c, lvl, s) for c in hf.CLASSES for lvl in (1, 2) for b in BLOCKS
           for s in range(b, b + (NONE_SEEDS if c == "none" else SEEDS))]
    out += [(f, c, lvl, s) for f in concealed.FAMILIES for c in concealed.CLASSES
            for lvl in (1, 2) for s in range(FAMILY_NONE_SEEDS if c == "none" else FAMILY_SEEDS)]
    return out


def table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (fam, lvl, v), g in df.groupby([df.family == "holdout", "level", "variant"],
                                       sort=False):
        ok = g.pick == g["class"]
        none = g["class"] == "none"
        rows.append({"data": "holdout blocks " + ", ".join(map(str, BLOCKS)) if fam else
                     "tuning families", "level": lvl, "variant": v,
                     "named right": rate_text(int(ok.sum()), len(g)),
                     "of 16, classes weighted equally": balanced_text(ok, g["class"]),
                     "`none` called physics": rate_text(int((g.pick[none] != "none").sum()),
                                                        int(none.sum())),
                     "dead band named": rate_text(
                         int((g.pick[g["class"] == "deadband"] == "deadband").sum()),
                         int((g["class"] == "deadband").sum())),
                     "stiction named": rate_text(
                         int((g.pick[g["class"] == "stiction"] == "stiction").sum()),
                         int((g["class"] == "stiction").sum()))})
    return pd.DataFrame(rows)


def verdict(df: pd.DataFrame) -> tuple[bool, list[str]]:
    """The criterion of the module docstring."""
    def count(g: pd.DataFrame, what: str) -> dict:
        m = (g.pick == g["class"]) if what == "right" else \
            ((g["class"] == "none") & (g.pick != "none"))
        return {(v, lvl): int(m[(g.variant == v) & (g.level == lvl)].sum())
                for v in VARIANTS for lvl in (1, 2)}

    hold, fams = df[df.family == "holdout"], df[df.family != "holdout"]
    r, fa, rf = count(hold, "right"), count(hold, "none"), count(fams, "right")
    c1 = (all(r["symmetric", lvl] >= r["shipped", lvl] for lvl in (1, 2))
          and sum(r["symmetric", lvl] for lvl in (1, 2)) > sum(r["shipped", lvl]
                                                               for lvl in (1, 2))
          and all(fa["symmetric", lvl] <= fa["shipped", lvl] for lvl in (1, 2)))
    c2 = all(rf["symmetric", lvl] >= rf["shipped", lvl] for lvl in (1, 2))
    lines = [f"- holdout blocks, level {lvl}: named right {r['shipped', lvl]} → "
             f"{r['symmetric', lvl]}, `none` called physics {fa['shipped', lvl]} → "
             f"{fa['symmetric', lvl]};" for lvl in (1, 2)]
    lines += [f"- tuning families, level {lvl}: named right {rf['shipped', lvl]} → "
              f"{rf['symmetric', lvl]};" for lvl in (1, 2)]
    lines.append(f"- item 1 {'met' if c1 else 'not met'}, item 2 "
                 f"{'met' if c2 else 'not met'}: **"
                 + ("adopted" if c1 and c2 else "not adopted") + "**.")
    return c1 and c2, lines


def report(df: pd.DataFrame) -> str:
    _, lines = verdict(df)
    piv = df.pivot_table(index=["family", "class", "level", "seed"], columns="variant",
                         values="pick", aggfunc="first").dropna()
    moved = piv[piv["shipped"] != piv["symmetric"]]
    return "\n".join([
        "# Both ends of the slip-jump test searched with the same effort",
        "",
        "Generated by `experiments/slip_jump_symmetric.py` (the candidate and the "
        "criterion fixed before the run are in its docstring): every class, a model "
        "given, shipped against the dead band refitted and the stick-slip valve "
        "restarted from it. Wilson 95 % intervals; the score of 16 weighs the classes "
        "equally (`rates.balanced_score`).",
        "",
        to_markdown(table(df)),
        "",
        f"Verdicts that moved: {len(moved)}"
        + (" — " + "; ".join(f"{f} {c} L{lvl} {s}: {r.shipped} → {r.symmetric}"
                              for (f, c, lvl, s), r in moved.iterrows()) if len(moved)
           else "") + ".",
        "",
        "## The criterion",
        "",
        *lines,
        ""])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite the report from slip_jump_symmetric.csv without diagnosing")
    a = ap.parse_args(argv)
    if a.report_only:
        df = pd.read_csv(OUT / "slip_jump_symmetric.csv")
    else:
        # the tasks by reference to this module imported by name (see band_magnitude.py)
        import slip_jump_symmetric as me
        from joblib import Parallel, delayed
        from tqdm import tqdm

        todo = [delayed(me.case)(*t, v) for t in tasks() for v in VARIANTS]
        df = pd.DataFrame(list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(todo),
                                    total=len(todo), desc="slip-jump, both ends")))
        with atomic_path(OUT / "slip_jump_symmetric.csv") as tmp:
            df.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")
    text = report(df)
    write_text(OUT / "slip_jump_symmetric.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
