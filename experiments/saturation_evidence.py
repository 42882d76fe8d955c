"""Why are level-2 travel limits missed? Count the samples that carry the evidence, and
vary the training/validation split.

``holdout_fresh.md`` reads the level-2 saturation misses as "NRMSE improvement < 10 %"
and "p ≥ 0.05": the fitted limit is often right (``holdout_sync_L2_saturation_5011``:
59.43 against a true 59.47) and still improves nothing on the validation blocks. A travel
limit acts only while OP is beyond it, and under a drifting load OP visits its extremes in
a few episodes. ``diagnose`` fits on blocks 1, 3, 5 of five and tests on blocks 2 and 4
(:data:`stictionbench.diagnosis.blocks.N_BLOCKS`); if the episodes fall in the training
blocks only, the validation blocks hold no sample where the hypothesis differs from the
nominal model, and no out-of-sample test can name it.

Three checks, nothing tuned here:

1. **Where the evidence is.** Saturation recordings of the holdout family
   (``experiments/holdout_family.py``: its own loop code, PI in step with the historian,
   noise and an integrated random-walk load at the issue's two levels), seeds
   :data:`FIRST_SEED` onwards at both levels. For each, the samples where the recorded OP
   is beyond the true limit, counted in the training and in the validation blocks, and
   the shipped verdict. If the explanation holds, the limit is named where the validation
   blocks hold such samples and almost never where they do not.
2. **The split, varied.** The same recordings diagnosed with the record cut into 9
   alternating blocks instead of 5 (training and validation then interleave more finely,
   so an episode is more often shared between them). If the misses came from the split's
   coarseness, the finer split would name more limits; if the episodes are too short or
   too rare to be shared, it would not.

3. **The start-up, cut off.** The family's loops start at OP = 50 %, so a limit below that
   clips the valve in the first seconds. Each recording is also diagnosed with its first
   :data:`TRIM_S` seconds removed: where a limit was named only from that start-up, it
   should no longer be.

Run: ``.venv/bin/python experiments/saturation_evidence.py [--seeds 24] [--jobs 2]``;
writes ``reports/concealed/saturation_evidence.md`` and ``saturation_evidence.csv``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import run  # noqa: E402
from holdout_family import generate  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.diagnosis.blocks import N_BLOCKS  # noqa: E402
from stictionbench.io import read_recording, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: first seed drawn (the block of ``make concealed``'s ``holdout_fresh.md``, whose misses
#: this explains, and the seeds after it)
FIRST_SEED = 5000
#: the shipped number of alternating blocks and the finer split it is compared with
SPLITS = (5, 9)
#: share of the validation samples beyond the limit below which the validation blocks are
#: said to hold no evidence
MIN_SHARE = 0.01
#: seconds cut from the start of a record to remove its start-up (a fifth of the
#: family's 3000 s)
TRIM_S = 600.0


def one(level: int, seed: int) -> dict:
    """Diagnose one saturation recording under each split; count OP beyond the limit."""
    with tempfile.TemporaryDirectory() as tmp:  # the files a user would give
        job = generate("saturation", level, seed, Path(tmp))
        rec = read_recording(job["csv"], warn=False)
        model = load_model(job["model"])
    limit = job["truth"]["op_high"]
    row = {"level": level, "seed": seed, "effect": job["effect"],
           "noise_frac": job["noise_frac"], "op_high": limit}
    op = np.asarray(rec.OP, float)
    beyond = op > limit
    shipped = N_BLOCKS
    for n_blocks in SPLITS:
        d = diagnose(rec, model, n_blocks=n_blocks)
        train, val = _split(rec, d)
        row[f"share_train_{n_blocks}"] = float(beyond[train].mean())
        row[f"share_val_{n_blocks}"] = float(beyond[val].mean())
        sat = {r["physics"]: r for r in d.ranking}["saturation"]
        row[f"verdict_{n_blocks}"] = d.missing_physics
        row[f"p_{n_blocks}"] = sat["p_value"]
        row[f"improvement_{n_blocks}"] = sat["improvement"]
        if n_blocks == shipped:
            row["share_start"] = float(beyond[:d.burn].mean())
    # the start-up removed: the record from TRIM_S on, diagnosed with the shipped split
    k = int(np.searchsorted(rec.t - rec.t[0], TRIM_S))
    trimmed = Recording.from_arrays(rec.t[k:], rec.PV[k:], rec.OP[k:], SP=rec.SP[k:],
                                    warn=False)
    row["verdict_trimmed"] = diagnose(trimmed, model).missing_physics
    return row


def _split(rec, d) -> tuple[np.ndarray, np.ndarray]:
    """Training and validation masks of a finished diagnosis: its validation windows,
    and every other sample after its burn-in."""
    t = np.asarray(rec.t, float)
    val = np.zeros(t.size, bool)
    for a, b in d.val_blocks:
        val |= (t >= a) & (t <= b)
    train = (np.arange(t.size) >= d.burn) & ~val
    return train, val


def _named(g: pd.DataFrame, which: int | str) -> str:
    """Limits named in ``g`` under a split (``5``, ``9``) or on the trimmed record."""
    return rate_text(int((g[f"verdict_{which}"] == "saturation").sum()), len(g))


def report(df: pd.DataFrame) -> str:
    """Named rates by where the evidence falls, and by split."""
    base = SPLITS[0]
    rows = []
    for level, g in df.groupby("level"):
        has = g[f"share_val_{base}"] >= MIN_SHARE
        for label, sub in (("validation blocks hold OP beyond the limit", g[has]),
                           ("they do not (< 1 % of their samples)", g[~has])):
            rows.append({"level": level, "recordings": label, "n": len(sub),
                         **{f"named, {k} blocks": _named(sub, k) if len(sub) else "–"
                            for k in SPLITS}})
    tab = pd.DataFrame(rows)
    none_val = df[df[f"share_val_{base}"] < MIN_SHARE]
    train_only = int((none_val[f"share_train_{base}"] >= MIN_SHARE).sum())
    start = none_val[(none_val[f"share_train_{base}"] < MIN_SHARE)
                     & (none_val["share_start"] > 0)]
    lines = [
        "# Level-2 travel limits: where the evidence is, and the split varied", "",
        f"Generated by `experiments/saturation_evidence.py` (`make concealed`): "
        f"{len(df)} saturation recordings of the holdout family, seeds {FIRST_SEED}–"
        f"{FIRST_SEED + df.seed.nunique() - 1} at each level (the first 12 were the blind "
        "block of `holdout_fresh.md` when this report was written), each diagnosed "
        "against its true model with the "
        f"record cut into {SPLITS[0]} alternating training/validation blocks (shipped) and "
        f"into {SPLITS[1]}. Rates carry Wilson 95 % intervals. Nothing is tuned here.", "",
        to_markdown(tab), "",
        f"- of the {len(none_val)} recordings whose validation blocks hold no OP beyond the "
        f"limit, {train_only} hold it in their training blocks (the limit is fitted "
        "there, and the validation blocks cannot test it); of the others, "
        f"{len(start)} ({', '.join(f'L{r.level} {r.seed}' for r in start.itertuples())}) "
        "have OP beyond the limit in the start-up before the first block (the loop "
        "starts at OP = 50 %, above a low limit) and in under 1 % of the blocks' "
        "samples; the process carries the start-up transient into the blocks: named "
        f"{_named(start, base)}, and {_named(start, 'trimmed')} with the first "
        f"{TRIM_S:.0f} s cut off (the start-up varied away; all recordings: "
        f"{_named(df, 'trimmed')} trimmed);",
        f"- all recordings: named {_named(df, SPLITS[0])} with {SPLITS[0]} blocks, "
        f"{_named(df, SPLITS[1])} with {SPLITS[1]};",
    ] + [
        f"- level {level}: median share of validation samples with OP beyond the limit "
        + (f"{g[f'share_val_{base}'].median():.2%} where the limit is named, "
           if len(g) else "none named, ")
        + (f"{g2[f'share_val_{base}'].median():.2%} where it is missed"
           if len(g2) else "none missed")
        for level, g_all in df.groupby("level")
        for g, g2 in [(g_all[g_all[f"verdict_{base}"] == "saturation"],
                       g_all[g_all[f"verdict_{base}"] != "saturation"])]] + [
        "",
        "Reading: at level 2 a limit is named mostly where the validation blocks hold OP "
        "beyond it (or the process carries a transient from it into them); where they "
        "hold none, nothing out of sample differs from the nominal model unless a "
        "transient from the limit reaches them. The range hypotheses' full-data test "
        "(`evidence.range_fallback`: the likelihood ratio on every block below 1e-10) "
        "names a limit only where the validation fit is not worse than the nominal's, "
        "which a limit reached in the training blocks alone does not meet: it names some "
        "limits reached in the start-up, not those. A finer split does not recover more: "
        "the episodes beyond the limit are few, so the split moves them between training "
        "and validation without adding any.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "concealed"))
    args = ap.parse_args(argv)
    todo = [(lvl, FIRST_SEED + k) for lvl in (1, 2) for k in range(args.seeds)]
    df = run(one, todo, args.jobs).sort_values(["level", "seed"], ignore_index=True)
    out = Path(args.out)
    write_text(out / "saturation_evidence.csv", df.to_csv(index=False, float_format="%.6g"))
    write_text(out / "saturation_evidence.md", report(df))
    print(report(df))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
