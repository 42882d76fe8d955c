"""The holdout family pooled over every seed block drawn so far, diagnosed by the code as shipped.

``holdout_fresh.md`` scores one block of fresh seeds (12 per physics class and level, 24
``none``); one block is a noisy estimate (level 2 moves by about one recording in 16
between blocks). This script runs the blocks of :data:`BLOCKS` (``holdout_family.py
--first-seed B --seeds 12 --none-seeds 24`` each, the package's default thresholds, a model
given) and reports them pooled, block by block, and against the loop's in-band degrees of
freedom ``band_dof`` (:func:`stictionbench.diagnosis.evidence.band_dof`: the independent
validation samples in the comparison band; slow loops have few).

**Which numbers are in-sample.** Every block but those of :data:`BLIND` (drawn after
the last rule change) was looked at while rules were chosen (``holdout_family.SEEN_FRESH``:
the band-dof gate and the range hypotheses' full-data test were checked on re-decisions
of their stored evidence), so the pooled rates are not blind; the report gives the blind
blocks' own rates beside them. No threshold was set on
this family.

Run: ``.venv/bin/python experiments/holdout_pooled.py [--cache DIR] [--jobs 2]``. Blocks
whose CSV is already in ``--cache`` (``h<B>.csv``, written by ``holdout_family.py --name
h<B> --out DIR`` at the same code) are read, not re-run. Outputs
``reports/concealed/holdout_pooled.{md,csv,png}``. About 2 min per block on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import holdout_family as hf  # noqa: E402

from stictionbench.diagnosis import load_model  # noqa: E402
from stictionbench.diagnosis.diagnose import after_comparison, compare  # noqa: E402
from stictionbench.diagnosis.gain import setpoint_gain  # noqa: E402
from stictionbench.diagnosis.op_limit import held_at_limit  # noqa: E402
from stictionbench.io import atomic_path, read_recording, write_text  # noqa: E402
from stictionbench.op_range import infer_op_range  # noqa: E402
from stictionbench.rates import balanced_score, balanced_text, fisher_p, rate_text, wilson  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: seed blocks of 12 seeds per physics class and level (24 for ``none``); 7000 is
#: ``slow_line.py``'s and 20000 ``slow_loops.py``'s, so they are not holdout blocks here.
#:
#: Since the causal comparison band (``openloop.comparison_band``) replaced the zero-phase
#: one, the blocks are those diagnosed at it: 16000–19000, on which the two bands were
#: compared before the switch (``causal_blind.md``), and 21000–26000, drawn after it
#: (25000 and 26000 by ``band_magnitude.py``, which changed no rule), and 27000–30000,
#: drawn blind and then the score of the slip-jump test's J = 0 refit with a model
#: (``slip_jump_nuisance.py``: a search change, no threshold, not adopted), and
#: 31000–34000, drawn blind for ``slip_jump_symmetric.py`` (not adopted either), and
#: 35000–38000, drawn blind with no candidate rule, to narrow the blind estimate, and
#: 39000, drawn blind to score the OP-hold check (``diagnosis.op_limit``: adopted; it
#: changed no verdict of the block), and 40000, drawn blind to score the set-point gain
#: test (``diagnosis.gain``: adopted).
#: Blocks 1000–15000 were pooled with the zero-phase band (this report at ``f45f3d5``
#: and its extension to 19000 in the commit that switched the band) and are not re-run.
BLOCKS = (16000, 17000, 18000, 19000, 21000, 22000, 23000, 24000, 25000, 26000, 27000,
          28000, 29000, 30000, 31000, 32000, 33000, 34000, 35000, 36000, 37000, 38000,
          39000, 40000)
#: blocks drawn after the last threshold or band change of the package (21000: ``make
#: concealed``'s ``holdout_fresh.md``), no rule chosen on them except by a criterion
#: stated before their run: their pooled rates are the blind estimate
BLIND = (21000, 22000, 23000, 24000, 25000, 26000, 27000, 28000, 29000, 30000, 31000,
         32000, 33000, 34000, 35000, 36000, 37000, 38000, 39000, 40000)
SEEDS, NONE_SEEDS = 12, 24
#: the first block diagnosed with the OP-hold check; the stored verdicts of earlier ones
#: are re-read with it (:func:`with_checks`)
HOLD_CHECKED_FROM = 39000
#: the first block diagnosed with the set-point gain test; the stored ``none`` verdicts of
#: earlier ones are re-read with it (:func:`with_checks`)
GAIN_CHECKED_FROM = 40000
#: in-band degrees of freedom bins of the report (the band-dof gate's reference is 100)
DOF_BINS = (0.0, 25.0, 35.0, 60.0, 100.0, 200.0, np.inf)
#: PV-noise bins, standard deviation as a fraction of the mean set-point step (the family
#: draws 1–4 % at level 1 and 3–10 % at level 2; the concealed set of issue 10 has "a few
#: per cent" at both levels)
NOISE_BINS = {1: (0.01, 0.025, 0.04), 2: (0.03, 0.05, 0.075, 0.10)}
#: effect-size bins (the family's effect: 0.4–1 at level 1, 0–0.5 at level 2)
EFFECT_BINS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0)
KEEP = ["name", "class", "level", "seed", "effect", "noise_frac", "predicted_default",
        "band_dof", "valve_model", "slip_jump_p"]


def block_rows(first: int, cache: Path, jobs: int) -> pd.DataFrame:
    """One block's stored diagnoses, every column (the evidence that
    ``concealed.decide`` re-decides included): read from ``cache`` or run by
    ``holdout_family.main``."""
    csv = cache / f"h{first}.csv"
    if not csv.is_file():
        hf.main(["--seeds", str(SEEDS), "--none-seeds", str(NONE_SEEDS), "--first-seed",
                 str(first), "--name", f"h{first}", "--jobs", str(jobs), "--out",
                 str(cache)])
    return pd.read_csv(csv)


def block(first: int, cache: Path, jobs: int) -> pd.DataFrame:
    """One block's rows as the report keeps them (:data:`KEEP`), the cycles of each
    oscillatory disturbance in the record (its true period from the stored truth) and
    the loop's drawn time constant ``tau`` (``holdout_family.draw`` again)."""
    df = block_rows(first, cache, jobs)
    osc = df["class"] == "oscillatory_disturbance"
    period = df.truth[osc].map(lambda t: json.loads(t)["period"])
    out = df[[c for c in KEEP if c in df]].copy()
    out["disturbance_cycles"] = (hf.DURATION / period).reindex(df.index)
    out["tau"] = [hf.draw(c, int(lv), int(sd)).tau
                  for c, lv, sd in zip(df["class"], df.level, df.seed, strict=True)]
    out["block"] = first
    out["gain_reread"] = False
    if first < GAIN_CHECKED_FROM:
        out["predicted_default"], out["gain_reread"] = with_checks(
            out, first, cache / f"h{first}_checks.csv", jobs)
    return out


def _checks(job: tuple[str, int, int]) -> tuple[str, bool, bool]:
    """One holdout recording made again (in a temporary directory): whether its OP is
    held at a limit (:func:`~stictionbench.diagnosis.op_limit.held_at_limit`, which reads
    OP alone) and whether the set-point gain test flags it
    (:func:`stictionbench.diagnosis.gain.setpoint_gain`: stage 1 of the diagnosis and the
    test, on the CSV and YAML read back as a user's)."""
    cls, level, seed = job
    c, sig = hf.make_recording(cls, level, seed)
    held = bool(held_at_limit(sig["OP"], infer_op_range(sig["OP"]))["held"])
    with tempfile.TemporaryDirectory() as tmp:
        j = hf.write_job(c, sig, Path(tmp))
        t = setpoint_gain(compare(read_recording(j["csv"], warn=False),
                                  load_model(j["model"])))
    return j["name"], held, bool(t.significant)


def with_checks(df: pd.DataFrame, first: int, cache: Path,
                jobs: int) -> tuple[pd.Series, pd.Series]:
    """Stored verdicts of a block diagnosed before the checks after the comparison
    re-read with them (:func:`stictionbench.diagnosis.diagnose.after_comparison`): the
    OP-hold check for blocks before :data:`HOLD_CHECKED_FROM`, the set-point gain test
    for blocks before :data:`GAIN_CHECKED_FROM`; only a ``none`` can change, every other
    verdict stands, as the checks leave it. Each ``none`` recording is made again once
    (:func:`_checks`) and its flags are kept in ``cache``. Returns the verdicts and where
    the gain test changed one."""
    pred = df["predicted_default"].copy()
    todo = df.index[pred == "none"]
    if cache.is_file():
        flags = pd.read_csv(cache)
    else:
        jobs_ = [(df.at[i, "class"], int(df.at[i, "level"]), int(df.at[i, "seed"]))
                 for i in todo]
        with ProcessPoolExecutor(jobs) as ex:
            got = list(ex.map(_checks, jobs_, chunksize=4))
        flags = pd.DataFrame(got, columns=["name", "op_held", "gain_flagged"])
        with atomic_path(cache) as tmp:
            flags.to_csv(tmp, index=False)
    f = flags.set_index("name")
    by_gain = pd.Series(False, index=df.index)
    for i in todo:
        n = df.at[i, "name"]
        new = after_comparison("none",
                               first < HOLD_CHECKED_FROM and bool(f.at[n, "op_held"]),
                               first < GAIN_CHECKED_FROM and bool(f.at[n, "gain_flagged"]))
        pred[i] = new
        by_gain[i] = new == "valve_characteristic"
    return pred, by_gain


def _gain_reread(df: pd.DataFrame) -> str:
    """How many stored ``none`` verdicts the set-point gain test re-read, by class."""
    hit = df[(df.block < GAIN_CHECKED_FROM)
             & (df.predicted_default == "valve_characteristic")
             & (df.get("gain_reread", pd.Series(False, index=df.index)))]
    if not len(hit):
        return "none changed"
    by = hit["class"].value_counts()
    return (f"{len(hit)} changed to `valve_characteristic`: "
            + ", ".join(f"{k} {v}" for k, v in by.items()))


def per16(ok: pd.Series, classes: pd.Series) -> str:
    """Recordings named correctly out of 16 drawn as the concealed set is (2 of each of
    the 8 classes, ``none`` one of them): the class-balanced score with its 95 % interval
    (:func:`stictionbench.rates.balanced_score`). The blocks hold twice as many ``none``
    recordings as any other class, so the pooled rate × 16 would weigh ``none`` (the class
    named right most often) 2/9 instead of 1/8."""
    return balanced_text(ok, classes, 16)


def level_rows(df: pd.DataFrame) -> list[dict]:
    """Per level: named correctly (all classes, out of 16), physics named, ``none``
    called physics."""
    ok = df.predicted_default == df["class"]
    rows = []
    for lvl in (1, 2):
        g = df.level == lvl
        phys, none = g & (df["class"] != "none"), g & (df["class"] == "none")
        rows.append({"level": lvl, "recordings": int(g.sum()),
                     "named correctly": rate_text(int(ok[g].sum()), int(g.sum())),
                     "of 16, classes weighted equally (95 % interval)":
                         per16(ok[g], df["class"][g]),
                     "pooled rate × 16 (`none` weighed 2/9)": round(16 * ok[g].mean(), 1),
                     "physics classes named": rate_text(int(ok[phys].sum()),
                                                        int(phys.sum())),
                     "`none` called physics": rate_text(int((~ok[none]).sum()),
                                                        int(none.sum()))})
    return rows


def by_block(df: pd.DataFrame) -> pd.DataFrame:
    """Each block's level-1 and level-2 score out of 16 and its false alarms."""
    ok = df.predicted_default == df["class"]
    rows = []
    for b, g in df.groupby("block"):
        row: dict = {"block": b, "status": "blind" if b in BLIND else "seen"}
        for lvl in (1, 2):
            m = g.level == lvl
            none = m & (g["class"] == "none")
            row[f"level {lvl} of 16"] = round(
                balanced_score(ok[g.index][m], g["class"][m], 16)[0], 1)
            row[f"level {lvl} none called physics"] = \
                f"{int((~ok[g.index][none]).sum())}/{int(none.sum())}"
        rows.append(row)
    return pd.DataFrame(rows)


def seen_against_blind(df: pd.DataFrame) -> list[str]:
    """The ``none`` recordings called physics on the seen blocks against the blind ones,
    per level, with Fisher's exact test: how much of the seen blocks' rate was selection
    (or chance)."""
    out = []
    for lvl in (1, 2):
        n = df[(df.level == lvl) & (df["class"] == "none")]
        fa = n.predicted_default != "none"
        b = n.block.isin(BLIND)
        k_s, n_s, k_b, n_b = int(fa[~b].sum()), int((~b).sum()), int(fa[b].sum()), int(b.sum())
        if n_s and n_b:
            out.append(f"- level {lvl}, `none` called physics: seen blocks "
                       f"{rate_text(k_s, n_s)}, blind blocks {rate_text(k_b, n_b)} "
                       f"(Fisher p = {fisher_p(k_s, n_s, k_b, n_b):.2g})")
    return out


def by_dof(df: pd.DataFrame) -> pd.DataFrame:
    """Named rate of the physics classes and the ``none`` false-alarm rate per level and
    in-band dof bin."""
    ok = df.predicted_default == df["class"]
    d = df.assign(ok=ok, bin=pd.cut(df.band_dof, DOF_BINS, right=False))
    rows = []
    for (lvl, b), g in d.groupby(["level", "bin"], observed=True):
        phys, none = g[g["class"] != "none"], g[g["class"] == "none"]
        rows.append({"level": lvl, "band_dof": f"{b.left:g}–{b.right:g}",
                     "physics named": rate_text(int(phys.ok.sum()), len(phys)),
                     "`none` called physics": rate_text(int((~none.ok).sum()), len(none)),
                     "_k": int(phys.ok.sum()), "_n": len(phys),
                     "_fa": int((~none.ok).sum()), "_nn": len(none),
                     "_mid": float(np.sqrt(max(b.left, 10.0) * min(b.right, 400.0)))})
    return pd.DataFrame(rows)


def by_effect(df: pd.DataFrame) -> pd.DataFrame:
    """Named rate of the physics classes per level and effect-size bin: the detectability
    curve (``none`` recordings have no effect and are left out)."""
    ok = df.predicted_default == df["class"]
    phys = df["class"] != "none"
    d = df[phys].assign(ok=ok[phys], bin=pd.cut(df.effect[phys], EFFECT_BINS,
                                                include_lowest=True))
    rows = []
    for (lvl, b), g in d.groupby(["level", "bin"], observed=True):
        rows.append({"level": lvl, "effect": f"{max(b.left, 0.0):.1f}–{b.right:.1f}",
                     "physics named": rate_text(int(g.ok.sum()), len(g)),
                     "_k": int(g.ok.sum()), "_n": len(g), "_mid": float(b.mid)})
    return pd.DataFrame(rows)


def by_noise(df: pd.DataFrame) -> pd.DataFrame:
    """Per level and PV-noise bin (:data:`NOISE_BINS`): the class-balanced score out of 16
    and the ``none`` false alarms. A description of where the score comes from, not a
    rule: nothing is chosen on it."""
    ok = df.predicted_default == df["class"]
    rows = []
    for lvl, edges in NOISE_BINS.items():
        g = df[df.level == lvl]
        labels = [f"{100 * a:g}–{100 * b:g}" for a, b in zip(edges[:-1], edges[1:], strict=True)]
        bins = pd.cut(g.noise_frac, edges, labels=labels, include_lowest=True)
        for b, h in g.groupby(bins, observed=True):
            none = h["class"] == "none"
            rows.append({"level": lvl, "PV noise, % of the set-point step": b,
                         "recordings": len(h),
                         "of 16, classes weighted equally": per16(ok[h.index],
                                                                  h["class"]),
                         "`none` called physics": rate_text(int((~ok[h.index][none]).sum()),
                                                            int(none.sum()))})
    return pd.DataFrame(rows)


#: bins of the process time constant (s; the family draws 3–120 s, sampled every 1 s)
TAU_BINS = (3.0, 10.0, 30.0, 60.0, 121.0)


def by_tau(df: pd.DataFrame) -> pd.DataFrame:
    """Per level and time-constant bin (:data:`TAU_BINS`): the class-balanced score out of
    16 and the ``none`` false alarms. A description, not a rule."""
    ok = df.predicted_default == df["class"]
    labels = [f"{a:g}–{min(b, 120.0):g}" for a, b in zip(TAU_BINS[:-1], TAU_BINS[1:],
                                                         strict=True)]
    rows = []
    for lvl in (1, 2):
        g = df[df.level == lvl]
        bins = pd.cut(g.tau, TAU_BINS, labels=labels)
        for b, h in g.groupby(bins, observed=True):
            none = h["class"] == "none"
            rows.append({"level": lvl, "process time constant τ (s)": b,
                         "record length / τ": f"{hf.DURATION / h.tau.max():.0f}–"
                                              f"{hf.DURATION / h.tau.min():.0f}",
                         "recordings": len(h),
                         "of 16, classes weighted equally": per16(ok[h.index], h["class"]),
                         "`none` called physics": rate_text(int((~ok[h.index][none]).sum()),
                                                            int(none.sum()))})
    return pd.DataFrame(rows)


#: bins of the oscillatory disturbances' cycles in the record (the search stops at two)
CYCLE_BINS = (0.0, 2.0, 3.0, 4.0, 6.0, np.inf)


def by_cycles(df: pd.DataFrame) -> pd.DataFrame:
    """Oscillatory disturbances named, per level and bin of the cycles their line makes
    in the record (:data:`CYCLE_BINS`; ``experiments/disturbance_cycles.py`` varies the
    cycle count alone)."""
    d = df[df["class"] == "oscillatory_disturbance"]
    labels = [f"{a:g}–{b:g}" if np.isfinite(b) else f"{a:g} and more"
              for a, b in zip(CYCLE_BINS[:-1], CYCLE_BINS[1:], strict=True)]
    bins = pd.cut(d.disturbance_cycles, CYCLE_BINS, labels=labels, right=False)
    rows = []
    for (lvl, b), g in d.groupby([d.level, bins], observed=True):
        ok = g.predicted_default == g["class"]
        rows.append({"level": lvl, "cycles in the record": b,
                     "disturbances named": rate_text(int(ok.sum()), len(g)),
                     "misses named": ", ".join(f"{k} ×{v}" for k, v in
                                               g.predicted_default[~ok].value_counts().items())
                     or "–"})
    return pd.DataFrame(rows)


def by_class(df: pd.DataFrame) -> pd.DataFrame:
    """Named rate per class and level, and what the misses were called."""
    ok = df.predicted_default == df["class"]
    rows = []
    for (cls, lvl), g in df.groupby(["class", "level"], sort=False):
        wrong = g.predicted_default[~ok[g.index]].value_counts()
        rows.append({"class": cls, "level": lvl,
                     "named correctly": rate_text(int(ok[g.index].sum()), len(g)),
                     "misses named": ", ".join(f"{k} ×{v}" for k, v in wrong.items()) or "–"})
    return pd.DataFrame(rows)


def _rates(ax, tab: pd.DataFrame, k: str, n: str) -> None:
    """Rates ``tab[k]/tab[n]`` per level against ``tab._mid`` with Wilson intervals."""
    for lvl, mk in ((1, "o-"), (2, "s--")):
        g = tab[(tab.level == lvl) & (tab[n] > 0)]
        p = g[k] / g[n]
        ci = np.array([wilson(int(a), int(b)) for a, b in zip(g[k], g[n], strict=True)])
        ax.errorbar(g._mid, p, yerr=[p - ci[:, 0], ci[:, 1] - p], fmt=mk, capsize=3,
                    label=f"level {lvl}")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)


def figure(dof: pd.DataFrame, eff: pd.DataFrame, out: Path) -> Path:
    """Named rate and false-alarm rate against the in-band dof, and the named rate
    against the effect size, with Wilson intervals."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    for ax, (k, n, title) in zip(axes[:2], (("_k", "_n", "physics classes named correctly"),
                                            ("_fa", "_nn", "`none` called physics")),
                                 strict=True):
        _rates(ax, dof, k, n)
        ax.set_xscale("log")
        ax.set_xticks([20, 30, 50, 100, 200, 400], ["20", "30", "50", "100", "200", "400"])
        ax.minorticks_off()
        ax.set_xlabel("in-band degrees of freedom (band_dof, bin centres)")
        ax.set_title(title, fontsize=10)
        ax.axvline(100, color="grey", lw=0.8, ls=":")
    axes[1].axhline(0.05, color="red", lw=0.8, ls=":", label="goal 5 %")
    _rates(axes[2], eff, "_k", "_n")
    axes[2].set_xlabel("effect size (family units)")
    axes[2].set_title("physics named against effect size", fontsize=10)
    axes[0].set_ylabel("share named correctly (Wilson 95 %)")
    axes[1].set_ylabel("share of `none` called physics")
    axes[2].set_ylabel("share named correctly (Wilson 95 %)")
    for ax in axes:
        ax.legend(fontsize=8)
    fig.tight_layout()
    path = out / "holdout_pooled.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def report(df: pd.DataFrame) -> str:
    blind = df[df.block.isin(BLIND)]
    names = ", ".join(map(str, BLIND))
    dof, eff = by_dof(df), by_effect(df)
    lines = [
        "# Holdout family pooled over its seed blocks",
        "",
        f"Generated by `experiments/holdout_pooled.py`: {len(df)} recordings, "
        f"{df.block.nunique()} blocks of 12 seeds per physics class and level (24 `none`), "
        "each diagnosed with a model given and the package's default thresholds, by the "
        "code as shipped (the blocks re-run, not their earlier verdicts). Rates carry "
        "Wilson 95 % intervals.",
        "",
        "**In-sample status.** Every block except "
        f"{names} was looked at while rules were chosen (`holdout_family.SEEN_FRESH`), so "
        f"the pooled rates are not blind; blocks {names} were drawn after the last "
        "threshold or band change and, pooled, are the blind estimate (27000–30000 then "
        "scored the slip-jump test's J = 0 refit and 31000–34000 its two-ended search, neither "
        "adopted: `slip_jump_nuisance.md`, `slip_jump_symmetric.md`; 35000–38000 were drawn "
        "with no candidate, to narrow the estimate; 39000 scored the OP-hold check, which "
        "changed none of its verdicts; the earlier blocks' `none` verdicts are re-read with "
        "it, which reads OP alone: `with_checks`; 40000 scored the set-point gain test, "
        "which changed none of its verdicts either; the earlier blocks' `none` verdicts "
        "are re-read with it, the recording made again, `with_checks`: "
        f"{_gain_reread(df)}). "
        "No threshold was set on this family.",
        "",
        "## Pooled",
        "",
        to_markdown(pd.DataFrame(level_rows(df))),
        "",
        f"## Blocks {names} pooled (blind)",
        "",
        to_markdown(pd.DataFrame(level_rows(blind))) if len(blind) else "(not run)",
        "",
        *seen_against_blind(df),
        "",
        "## Block by block",
        "",
        to_markdown(by_block(df)),
        "",
        "## Against the in-band degrees of freedom",
        "",
        "Slow loops (time constant of a minute and more at 1 s sampling) leave few "
        "independent validation samples in the comparison band; below 100 the NRMSE gate "
        "is widened (`evidence.scaled_gate`).",
        "",
        f"![named and false-alarm rates against band dof and effect size]"
        f"({figure(dof, eff, OUT).name})",
        "",
        to_markdown(dof[[c for c in dof if not c.startswith("_")]]),
        "",
        "## Against the effect size (detectability)",
        "",
        "The family draws the effect uniformly, 0.4–1 at level 1 and 0–0.5 at level 2 "
        "(`holdout_family.draw`: e.g. a stick band S = 0.5 + 5.5·effect % of OP, a dead "
        "band 0.5 + 4.5·effect %); the table gives the named rate per effect bin.",
        "",
        to_markdown(eff[[c for c in eff if not c.startswith("_")]]),
        "",
        "## Against the PV noise (blind blocks)",
        "",
        "The PV noise's standard deviation as a share of the mean set-point step, drawn "
        "uniformly per recording (1–4 % at level 1, 3–10 % at level 2). The concealed set "
        "the issue is judged on has \"a few per cent\" at both levels, so its level-2 "
        "recordings are likelier to look like the lower bins than like the pooled rate. "
        "A description only: no threshold is read from it.",
        "",
        to_markdown(by_noise(blind)) if len(blind) else "(not run)",
        "",
        "## Against the loop's time constant (blind blocks)",
        "",
        "The family draws τ log-uniformly from 3 to 120 s, every loop sampled at 1 s for "
        "3000 s. The paper's process has τ = 10 s. A slow loop leaves few independent "
        "samples in its band (the in-band degrees of freedom above): "
        "[slow_loops_named.md](slow_loops_named.md) varies the speed alone, and the "
        "record's length, on faulty loops, [slow_loops.md](slow_loops.md) on healthy ones.",
        "",
        to_markdown(by_tau(blind)) if len(blind) else "(not run)",
        "",
        "## Oscillatory disturbances against the cycles in the record (blind blocks)",
        "",
        "The family draws the line's period from 2 to 50 closed-loop time constants, so on "
        "slow loops it may make fewer than two cycles in the 3000 s record; the search "
        "stops at two cycles by design ([disturbance_cycles.md](disturbance_cycles.md) "
        "varies the cycle count alone on loops of the same family).",
        "",
        to_markdown(by_cycles(blind)) if len(blind) else "(not run)",
        "",
        "## Class by class, pooled",
        "",
        to_markdown(by_class(df)),
        "",
    ]
    return "\n".join(lines)


OUT = ROOT / "reports" / "concealed"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", default=str(ROOT / ".cache" / "holdout_blocks"),
                    help="where block CSVs are kept (read when present)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--stored", action="store_true",
                    help="rewrite the report from holdout_pooled.csv without diagnosing")
    a = ap.parse_args(argv)
    if a.stored:
        df = pd.read_csv(OUT / "holdout_pooled.csv", keep_default_na=False,
                         na_values={c: [""] for c in ("slip_jump_p", "band_dof",
                                                     "disturbance_cycles")})
    else:
        cache = Path(a.cache)
        cache.mkdir(parents=True, exist_ok=True)
        df = pd.concat([block(b, cache, a.jobs) for b in BLOCKS], ignore_index=True)
        with atomic_path(OUT / "holdout_pooled.csv") as tmp:
            df.round({"effect": 6, "noise_frac": 6, "band_dof": 2}).to_csv(
                tmp, index=False, lineterminator="\n", float_format="%.6g")
    text = report(df)
    write_text(OUT / "holdout_pooled.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
