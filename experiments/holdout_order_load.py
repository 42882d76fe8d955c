"""The likelihood tests' high-pass order against the load's drift and the loop's speed, on
the holdout family: why order 0 names less at level 2 there, checked by varying the load
alone and the time constant alone.

Order 0 (``diagnose --test-highpass-order 0``) halves the healthy loops the independent
sets call physics (``likelihood_highpass.md``, ``size_power.md``). Tried as the default on
2026-11-28 (branch ``order0``, not merged), it took the holdout family's level 2 on the
blind blocks from 12.3 to 10.6 of 16, level 1 and the healthy loops losing nothing. The
explanation on offer was the one ``likelihood_highpass.py`` gave for generator A: without
the comparison band's two zeros at DC, the innovations of the load's drift stay in both
models' prediction errors and dilute the likelihood ratio, and the holdout family's load
is an *integrated* random walk whose spread at level 2 is 0.3–1 set-point step (0.05–0.2
at level 1). If that holds, order 0's loss against order 2 shrinks when the same loops are
recorded with a tenth of the load, their noise, set points and effects unchanged.

It does not hold (the report): the loss stays. What the first run left was an
observation: the recordings only order 2 names are the slower loops (median τ 28.6 s
against 20.4 s where both name the effect). If slowness is the cause, order 0's loss
grows when the same loops are moved to a slow time constant and shrinks at a fast one,
their ``θ/τ``, ``λ/τ``, effects in units of the loop's speed, noise and load unchanged
(:func:`holdout_family.at_speed`). The second axis, :data:`TAUS`, checks that.

Design (nothing tuned here): level-2 recordings of the holdout family
(``experiments/holdout_family.py``), every class, seeds from :data:`FIRST_SEED` (a block no
other experiment draws), each recorded with its load's spread scaled by every factor of
:data:`LOAD_SCALES` (:func:`holdout_family.at_speed` at the loop's own time constant),
and also at its drawn load with every time constant of :data:`TAUS` (the family draws τ
from 3 to 120 s), each recording diagnosed against its true model under orders 2 and 0
at the package's thresholds. Reported: per variant and order the score of 16 (classes
weighted equally), physics named and healthy loops called physics (Wilson 95 %), the
paired change between the orders (exact McNemar test), and whether each order's test
fitted an integrated noise model (the CSV holds its AR order too).

Run: ``.venv/bin/python experiments/holdout_order_load.py [--seeds 12] [--jobs 2]
[--reuse]``;
writes ``reports/concealed/holdout_order_load.{md,csv}``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fresh_recordings as fresh  # noqa: E402
import holdout_family as hf  # noqa: E402
from concealed import write_job  # noqa: E402
from concealed_families import CLASSES  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording, write_text  # noqa: E402
from stictionbench.rates import balanced_text, mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import csv_text, to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
FIRST_SEED = 48000
SEEDS = 12
LEVEL = 2
#: the load's spread, as a multiple of the drawn one
LOAD_SCALES = (1.0, 0.1)
ORDERS = (2, 0)
#: the loop's time constant (s) of the speed axis, at the drawn load
TAUS = (8.0, 60.0)


def variants() -> list[tuple[float, float | None]]:
    """Every ``(load scale, τ)`` recorded; ``τ`` ``None`` is the loop's drawn one."""
    return [(s, None) for s in LOAD_SCALES] + [(1.0, t) for t in TAUS]


def _label(scale: float, tau: float | None) -> str:
    return f"load {scale:g}" if tau is None else f"τ {tau:g} s"


def _with_tau(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with its ``tau`` column (``NaN``: the drawn one) even from rows without it."""
    return df if "tau" in df else df.assign(tau=float("nan"))


def jobs(seeds: int, out: Path) -> list[dict]:
    """Every (load scale, class, seed) written as a recording and its model YAML."""
    todo = []
    for scale, tau in variants():
        sub = out / f"load_{scale:g}_tau_{'drawn' if tau is None else f'{tau:g}'}"
        sub.mkdir(parents=True, exist_ok=True)
        for cls in CLASSES:
            for seed in range(FIRST_SEED, FIRST_SEED + seeds):
                t = hf.draw(cls, LEVEL, seed).tau if tau is None else tau
                c, sig = hf.at_speed(cls, LEVEL, seed, t, load_scale=scale)
                todo.append(write_job(c, sig, sub) | {
                    "load_scale": scale, "tau": float("nan") if tau is None else tau})
    return todo


def run(job: dict) -> dict:
    """One recording diagnosed against its true model under every order of :data:`ORDERS`."""
    rec = read_recording(job["csv"], warn=False)
    model = load_model(job["model"])
    row = {k: job[k] for k in ("load_scale", "tau", "class", "seed")}
    for o in ORDERS:
        d = diagnose(rec, model, test_highpass_order=o)
        row[f"order_{o}"] = d.missing_physics
        row[f"integrated_{o}"] = bool(d.noise_model.get("integrated", False))
        row[f"ar_order_{o}"] = int(d.noise_model.get("ar_order", 0))
    return row


def _groups(df: pd.DataFrame):
    """``(label, rows)`` per recorded variant, in :func:`variants` order."""
    df = _with_tau(df)
    for scale, tau in variants():
        m = df.load_scale == scale
        m &= df.tau.isna() if tau is None else df.tau == tau
        if m.any():
            yield (scale, tau), df[m]


def table(df: pd.DataFrame) -> pd.DataFrame:
    """Per variant (load scale, time constant) and order: the score of 16, physics named,
    healthy loops called physics; and the discordant pairs against order 2."""
    rows = []
    for (scale, tau), g in _groups(df):
        h = g["class"] == "none"
        ok2 = g["order_2"] == g["class"]
        for o in ORDERS:
            ok = g[f"order_{o}"] == g["class"]
            gained, lost = int((ok & ~ok2).sum()), int((ok2 & ~ok).sum())
            rows.append({
                "load (× drawn)": scale, "τ (s)": "drawn" if tau is None else f"{tau:g}",
                "order": o,
                "of 16": balanced_text(ok, g["class"]),
                "physics named": rate_text(int(ok[~h].sum()), int((~h).sum())),
                "healthy called physics": rate_text(int((~ok[h]).sum()), int(h.sum())),
                "right only with this order / only with order 2":
                    "" if o == 2 else f"{gained} / {lost} (p = {mcnemar_p(gained, lost):.2g})"})
    return pd.DataFrame(rows)


def by_class(df: pd.DataFrame) -> pd.DataFrame:
    """Named right per class, variant and order (counts of the class's recordings)."""
    groups = list(_groups(df))
    rows = []
    for cls in CLASSES:
        row = {"class": cls}
        for (scale, tau), g in groups:
            g = g[g["class"] == cls]
            for o in ORDERS:
                row[f"{_label(scale, tau)}, order {o}"] = \
                    f"{int((g[f'order_{o}'] == cls).sum())}/{len(g)}"
        rows.append(row)
    return pd.DataFrame(rows)


def reading(df: pd.DataFrame) -> str:
    """Order 0's loss against order 2 at each load scale and at each time constant,
    physics recordings only."""
    df = _with_tau(df)
    parts, diff = [], {}
    for scale in LOAD_SCALES:
        g = df[(df.load_scale == scale) & df.tau.isna() & (df["class"] != "none")]
        d = diff[scale] = _loss(g)
        parts.append(f"{d:+d} of {len(g)} at {scale:g}× the drawn load")
    full, low = diff[max(LOAD_SCALES)], diff[min(LOAD_SCALES)]
    if full >= 0:
        verdict = "order 0 loses nothing here with the drawn load, so there is no loss to explain"
    elif abs(low) <= abs(full) / 2:
        verdict = ("the loss shrinks to half or less with the load: consistent with the "
                   "drift's innovations diluting order 0's likelihood ratio")
    else:
        verdict = ("the loss does not shrink with the load: on this family the load's drift "
                   "is not what order 0 loses to")
    return ("Reading: physics recordings named right by order 0 minus order 2: "
            + "; ".join(parts) + f"; {verdict}. " + noise_reading(df) + speed_reading(df))


def _loss(g: pd.DataFrame) -> int:
    """Physics recordings order 0 names right minus those order 2 does."""
    g = g[g["class"] != "none"]
    return int((g.order_0 == g["class"]).sum()) - int((g.order_2 == g["class"]).sum())


def _pairs(g: pd.DataFrame) -> str:
    """The discordant physics recordings (right only with order 0 / only with order 2)
    and their exact McNemar p."""
    g = g[g["class"] != "none"]
    ok0, ok2 = g.order_0 == g["class"], g.order_2 == g["class"]
    gained, lost = int((ok0 & ~ok2).sum()), int((ok2 & ~ok0).sum())
    return f"{gained} / {lost}, p = {mcnemar_p(gained, lost):.2g}"


def speed_reading(df: pd.DataFrame) -> str:
    """Order 0's loss against order 2 at each time constant of :data:`TAUS` (drawn load):
    the check of the observation that the recordings it loses are the slower loops. The
    same rule as the load's: the reading holds when the loss at the fast time constant is
    half or less of the loss at the slow one."""
    df = _with_tau(df)
    got = [(t, df[(df.tau == t) & (df.load_scale == 1.0)]) for t in TAUS]
    got = [(t, g) for t, g in got if len(g)]
    if len(got) < 2:
        return ""
    (fast, gf), (slow, gs) = got[0], got[-1]
    lf, ls = _loss(gf), _loss(gs)
    n = int((gs["class"] != "none").sum())
    if ls >= 0:
        verdict = (f"order 0 loses nothing at τ {slow:g} s, so the loop's slowness is not "
                   "what it loses to")
    elif abs(min(lf, 0)) <= abs(ls) / 2:
        verdict = ("the loss grows with the time constant: the slower the loop, the more "
                   "order 0 loses, as the observation suggested")
    else:
        verdict = ("the loss does not grow with the time constant: the loop's slowness is "
                   "not what order 0 loses to either")
    return (f" Varied (the same loops at τ {fast:g} s and τ {slow:g} s, drawn load): order "
            f"0 minus order 2 {lf:+d} of {n} at τ {fast:g} s ({_pairs(gf)}), {ls:+d} of {n} "
            f"at τ {slow:g} s ({_pairs(gs)}); {verdict}.")


def noise_reading(df: pd.DataFrame) -> str:
    """How often order 0's noise model is integrated on the physics recordings only
    order 2 names right, against those both name right: an integrated autoregressive
    predictor follows a slow mismatch from one sample to the next, so a slow effect
    leaves the one-step errors of both models alike."""
    if "integrated_0" not in df:
        return ""
    g = _with_tau(df)
    g = g[g.tau.isna() & (g["class"] != "none")]
    ok2, ok0 = g.order_2 == g["class"], g.order_0 == g["class"]
    parts = []
    for label, m in (("named only by order 2", ok2 & ~ok0), ("named by both", ok2 & ok0),
                     ("named only by order 0", ok0 & ~ok2)):
        k = int(g.integrated_0[m].sum())
        parts.append(f"{label} {rate_text(k, int(m.sum()))}")
    tau = pd.Series([hf.draw(c, LEVEL, s).tau for c, s in zip(g["class"], g.seed,
                                                               strict=True)], index=g.index)
    slow = "; ".join(f"{label} {tau[m].median():.1f} s" for label, m in
                     (("named only by order 2", ok2 & ~ok0), ("by both", ok2 & ok0),
                      ("only by order 0", ok0 & ~ok2), ("by neither", ~ok2 & ~ok0))
                     if m.any())
    both = ok2 & ok0
    common = bool(both.any()) and float(g.integrated_0[both].mean()) >= 0.5
    return ("Order 0's noise model integrated, on the physics recordings "
            + "; ".join(parts) + f" (order 2's: {int(g.integrated_2.sum())} of {len(g)})"
            + (": as often where order 0 names the effect, so not what tells the "
               "recordings it loses apart" if common else "")
            + f". The loops' median time constant at their drawn speed: {slow}.")


def main(argv: list[str] | None = None) -> int:
    a = fresh.seeds_jobs_args(__doc__, "holdout_order_load", SEEDS, argv,
                              reuse_help="re-make the report from the stored CSV")
    if a is None:
        return 2
    csv = OUT / "holdout_order_load.csv"
    if a.reuse:
        if not csv.is_file():
            print(f"holdout_order_load: {csv}: no such file (run without --reuse)",
                  file=sys.stderr)
            return 2
        df = pd.read_csv(csv)
    else:
        df = fresh.run_written(run, jobs, a.seeds, a.jobs)
        df = df.sort_values(["load_scale", "tau", "class", "seed"],
                            ascending=[False, True, True, True], na_position="first",
                            kind="stable").reset_index(drop=True)
        write_text(csv, csv_text(df))
    text = "\n".join([
        "# The high-pass order against the load's drift and the loop's speed, on the "
        "holdout family", "",
        "Generated by `experiments/holdout_order_load.py` (the design is in its "
        f"docstring): level-{LEVEL} recordings of the holdout family, every class, seeds "
        f"{FIRST_SEED}–{int(df.seed.max())}, each recorded with its drawn load and "
        "with a tenth of it (noise, set points and effect unchanged), and at its drawn load "
        f"with the time constants {', '.join(f'{t:g}' for t in TAUS)} s (θ/τ, λ/τ and the "
        "effect in the loop's units kept), diagnosed against "
        "its true model under the likelihood tests' high-pass of order 2 and of order 0 at "
        "the package's thresholds; Wilson 95 % intervals; nothing tuned here.", "",
        to_markdown(table(df)), "",
        to_markdown(by_class(df)), "",
        reading(df), "",
    ])
    write_text(OUT / "holdout_order_load.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
