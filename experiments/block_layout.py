"""The slow-line false alarms checked by varying what the reading of them depends on: the
validation blocks' layout and the load.

Eight of the 22 healthy loops that ``diagnose`` calls faulty on the independent sets A–I
(``independent_set.py``) are named an oscillatory disturbance, seven on slow loops, five with
a fitted period of 520–1310 s in a 3000 s record. The reading in ``docs/diagnosis.md``: the
integrated random-walk load wanders, a slow line fitted on the training blocks (the first,
third and fifth of five, :mod:`stictionbench.diagnosis.blocks`) follows the wander there,
and the validation blocks, each between two training blocks, are an interpolation of it, so
the line "predicts" the validation blocks though nothing periodic is in the loop.

That reading predicts, before the run:

1. without the load (``no_load``: the generator's own load multiplied by 0, every other
   draw the same; :func:`healthy_false_alarms.remake`, ``remake_c``) the oscillatory
   false alarms go;
2. with a one-sided layout (``train_first``: fit the first three blocks, judge the last
   two; ``validation_first``: the other way round), where validation is a forecast past
   the fitted span, not an interpolation inside it, most of them go too, while true
   disturbance lines, which repeat, are still named;
3. the number of interleaved blocks matters less than the interleaving (``n3``: three
   blocks, validation the middle one; ``n9``: nine).

Added after the first run, to check its reading of prediction 2 (the one-sided layouts lost
generator C's true lines, not generator A's; C's disturbance wanders in frequency and
amplitude, A's is a fixed sinusoid):

4. generator C's disturbance recordings re-made without the wander (``no_wander``: the two
   Ornstein–Uhlenbeck paths of its stream 5 set to zero after they are drawn, so the
   phase and every other draw are the same; a fixed sinusoid with its harmonics) keep
   their lines under ``train_first`` as generator A's do (nine tenths of the interleaved
   split's count).

Recordings: every healthy (``none``) and oscillatory-disturbance recording of sets A–I
(``.cache/blindgen``, written by ``make independent``; 432), each diagnosed with its model
YAML under the shipped defaults and each layout (``diagnose(..., n_blocks=,
block_layout=)``); the healthy ones also re-made without the load and diagnosed with the
shipped layout. ``interleaved`` must reproduce the stored verdicts of
``independent_set_*.csv`` (checked, counted in the report). Nothing here changes a default
or sets a threshold; the shipped layout stays whatever this finds, and the report says so.

Run: ``.venv/bin/python experiments/block_layout.py [--jobs 2] [--reuse]``; writes
``reports/concealed/block_layout.{md,csv,png}`` (about 25 minutes on 2 cores).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import healthy_false_alarms as hfa  # noqa: E402
from fresh_recordings import generator_module, jobs_reuse_args, publish, rate_bars, run  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

DATA = ROOT / ".cache" / "blindgen"
OUT = ROOT / "reports" / "concealed"
SETS = {"A": hfa.SETS, "C": hfa.SETS_C}
CLASSES = ("none", "oscillatory_disturbance")
#: variant → (n_blocks, layout) of the diagnosis; ``no_load`` re-makes the recording
LAYOUT_VARIANTS = {"interleaved": (5, "interleaved"), "train_first": (5, "train_first"),
                   "validation_first": (5, "validation_first"), "n3": (3, "interleaved"),
                   "n9": (9, "interleaved")}
VARIANTS = (*LAYOUT_VARIANTS, "no_load")
#: generator C's disturbances re-made without the wander, under two layouts (prediction 4)
WANDER_VARIANTS = {"no_wander": "interleaved", "no_wander+train_first": "train_first"}
SHIPPED = "interleaved"
LINE = "oscillatory_disturbance"
#: fewer independent in-band validation samples than this: a slow loop (as in
#: ``docs/diagnosis.md``'s reading of these false alarms)
SLOW_DOF = 50


def _row(r, gen: str, set_: str, name: str, level: int, cls: str, variant: str) -> dict:
    line = next((x for x in r.ranking if x.get("physics") == LINE), {})
    period = (r.parameters.get("period") if r.missing_physics == LINE
              else (line.get("parameters") or {}).get("period"))
    return {"generator": gen, "set": set_, "name": name, "level": level, "class": cls,
            "variant": variant, "predicted": r.missing_physics,
            "line_p": line.get("p_value"), "line_improvement": line.get("improvement"),
            "line_period": period, "band_dof": r.details.get("band_dof")}


def remake_without_wander(seed: int, level: int, out: Path) -> str:
    """Generator C's oscillatory-disturbance recording of ``seed`` re-made with the
    wander of its frequency and amplitude set to zero (its stream 5's normal draws are
    made, then returned as zeros: the phase and every other draw are unchanged); the name
    written."""
    g = generator_module("blind_generator_c")
    stream = g.stream

    class Still:
        def __init__(self, rng):
            self.rng = rng

        def standard_normal(self, n):
            self.rng.standard_normal(n)
            return np.zeros(n)

        def __getattr__(self, attr):
            return getattr(self.rng, attr)

    g.stream = lambda seed_, tag: Still(stream(seed_, tag)) if tag == 5 else stream(seed_, tag)
    res = g.make_recording(seed, level, LINE)
    g.write_recording(str(out), res)
    return res["name"]


def one(gen: str, set_: str, name: str, seed: int, level: int, cls: str,
        variant: str) -> dict:
    """One recording of set ``set_`` diagnosed under ``variant``."""
    if variant in WANDER_VARIANTS:
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            if remake_without_wander(seed, level, d) != name:
                raise RuntimeError(f"seed {seed} does not make {name}")
            rec = read_recording(str(d / f"{name}.csv"), warn=False)
            r = diagnose(rec, load_model(d / f"{name}.model.yaml"),
                         block_layout=WANDER_VARIANTS[variant])
        return _row(r, gen, set_, name, level, cls, variant)
    if variant == "no_load":
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            if gen == "A":
                hfa.remake(seed, level, "no_load", d, name, cls)
            else:
                hfa.remake_c(seed, level, "no_load", d, cls)
            rec = read_recording(str(d / f"{name}.csv"), warn=False)
            r = diagnose(rec, load_model(d / f"{name}.model.yaml"))
    else:
        n_blocks, layout = LAYOUT_VARIANTS[variant]
        src = DATA / f"set_{set_}"
        rec = read_recording(str(src / f"{name}.csv"), warn=False)
        r = diagnose(rec, load_model(src / f"{name}.model.yaml"), n_blocks=n_blocks,
                     block_layout=layout)
    return _row(r, gen, set_, name, level, cls, variant)


def cases() -> tuple[list[tuple], pd.DataFrame]:
    """Every job, and the stored verdicts and truth of the recordings."""
    todo, stored = [], []
    for gen, sets in SETS.items():
        for s in sets:
            d = pd.read_csv(OUT / f"independent_set_{s}.csv")
            d = d[d["class"].isin(CLASSES)]
            true_period = d["disturbance_period"] if gen == "A" else d["osc_period"]
            stored.append(pd.DataFrame({"set": s, "name": d["name"], "stored": d.predicted,
                                        "true_period": true_period}))
            for _, t in d.iterrows():
                vs = (VARIANTS if t["class"] == "none" else
                      (*LAYOUT_VARIANTS, *WANDER_VARIANTS) if gen == "C" else
                      tuple(LAYOUT_VARIANTS))
                todo += [(gen, s, t["name"], int(t.seed), int(t.level), t["class"], v)
                         for v in vs]
    return todo, pd.concat(stored, ignore_index=True)


def _flags(df: pd.DataFrame) -> pd.DataFrame:
    return df.assign(fa=(df["class"] == "none") & (df.predicted != "none"),
                     fa_line=(df["class"] == "none") & (df.predicted == LINE),
                     right=df.predicted == df["class"],
                     slow=df.band_dof < SLOW_DOF)


def _paired(df: pd.DataFrame, variant: str, col: str) -> str:
    w = df[df.variant.isin((SHIPPED, variant))].pivot_table(
        index=["set", "name"], columns="variant", values=col, aggfunc="first").dropna()
    if variant == SHIPPED or variant not in w:
        return "—"
    a, b = w[variant].astype(bool), w[SHIPPED].astype(bool)
    only_v, only_s = int((a & ~b).sum()), int((b & ~a).sum())
    return f"{only_v} / {only_s} (p = {mcnemar_p(only_v, only_s):.2g})"


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per variant and generator: healthy loops called physics and called a line, and the
    oscillatory disturbances named right, with the paired changes against the shipped
    layout."""
    rows = []
    for v in VARIANTS:
        for gen in (*SETS, "both"):
            d = df[(df.variant == v) & ((df.generator == gen) if gen != "both" else True)]
            h, o = d[d["class"] == "none"], d[d["class"] == LINE]
            dd = df if gen == "both" else df[df.generator == gen]
            rows.append({
                "variant": v, "generator": gen,
                "healthy called physics": rate_text(int(h.fa.sum()), len(h)),
                "healthy called a line": rate_text(int(h.fa_line.sum()), len(h)),
                "of them slow loops": f"{int((h.fa_line & h.slow).sum())}",
                "line only here / only shipped": _paired(dd[dd["class"] == "none"], v,
                                                         "fa_line"),
                "disturbances named, level 1": (rate_text(int(o[o.level == 1].right.sum()),
                                                          int((o.level == 1).sum()))
                                                if len(o) else "—"),
                "level 2": (rate_text(int(o[o.level == 2].right.sum()),
                                      int((o.level == 2).sum())) if len(o) else "—"),
                "named only here / only shipped": (_paired(dd[dd["class"] == LINE], v,
                                                           "right") if len(o) else "—"),
            })
    return pd.DataFrame(rows)


def shipped_line_alarms(df: pd.DataFrame) -> pd.DataFrame:
    """The healthy loops the shipped layout names a line, under every variant."""
    h = df[df["class"] == "none"]
    names = h[(h.variant == SHIPPED) & h.fa_line].name
    w = h[h.name.isin(names)].pivot_table(index=["set", "name"], columns="variant",
                                          values="predicted", aggfunc="first")
    per = h[(h.variant == SHIPPED) & h.name.isin(names)].set_index(["set", "name"])
    w.insert(0, "fitted period (s)", per.line_period.reindex(w.index).round(0))
    w.insert(0, "band dof", per.band_dof.reindex(w.index).round(0))
    return w[["band dof", "fitted period (s)", *VARIANTS]].reset_index()


def _wander_pairs(df: pd.DataFrame) -> pd.DataFrame:
    """Generator C's disturbance rows of the recordings also re-made without the wander."""
    d = df[(df.generator == "C") & (df["class"] == LINE)]
    return d[d.name.isin(d[d.variant == "no_wander"].name)]


def wander_table(df: pd.DataFrame) -> pd.DataFrame:
    """Generator C's disturbances named right under the interleaved and the forecast
    layout, as recorded and without the wander, by level."""
    d = _wander_pairs(df)
    rows = []
    for v in ("interleaved", "train_first", *WANDER_VARIANTS):
        g = d[d.variant == v]
        row = {"variant": v}
        for lv in (1, 2):
            gl = g[g.level == lv]
            row[f"named, level {lv}"] = rate_text(int(gl.right.sum()), len(gl))
        row["both"] = rate_text(int(g.right.sum()), len(g))
        rows.append(row)
    return pd.DataFrame(rows)


def _wander_lines(df: pd.DataFrame) -> list[str]:
    if "no_wander" not in set(df.variant):
        return []
    d = _wander_pairs(df)
    n = {v: int(d[d.variant == v].right.sum())
         for v in ("interleaved", "train_first", *WANDER_VARIANTS)}
    total = int((d.variant == "no_wander").sum())
    held = n["no_wander+train_first"] >= 0.9 * n["no_wander"]
    return [f"- **Prediction 4 (the wander)**: generator C's {total} disturbances named "
            f"{n['interleaved']} interleaved → {n['train_first']} forecast as recorded, "
            f"{n['no_wander']} → {n['no_wander+train_first']} without the wander. "
            + ("Held: without the wander the forecast keeps nine tenths of the lines, so "
               "the wander is what the forecast layout cannot follow." if held else
               "Not held: the forecast loses the lines without the wander too, so the "
               "wander is not (alone) why; the loss is not explained here.")]


def _count(df: pd.DataFrame, variant: str, col: str, cls: str) -> int:
    return int(df[(df.variant == variant) & (df["class"] == cls)][col].sum())


def report(df: pd.DataFrame, reproduced: tuple[int, int]) -> str:
    df = _flags(df)
    alarms = shipped_line_alarms(df)
    n_alarms = len(alarms)
    gone = {v: int((alarms[v] == "none").sum()) for v in VARIANTS if v != SHIPPED}
    still = {v: int((alarms[v] == LINE).sum()) for v in VARIANTS if v != SHIPPED}
    named = {v: _count(df, v, "right", LINE) for v in LAYOUT_VARIANTS}
    n_osc = int(((df.variant == SHIPPED) & (df["class"] == LINE)).sum())
    fa_line = {v: _count(df, v, "fa_line", "none") for v in VARIANTS}
    fa = {v: _count(df, v, "fa", "none") for v in VARIANTS}
    n_h = int(((df.variant == SHIPPED) & (df["class"] == "none")).sum())
    one_sided = ("train_first", "validation_first")
    by_gen = {(v, g): _count(df[df.generator == g], v, "right", LINE)
              for v in LAYOUT_VARIANTS for g in SETS}
    n_gen = {g: int(((df.variant == SHIPPED) & (df["class"] == LINE)
                     & (df.generator == g)).sum()) for g in SETS}
    held_1 = still["no_load"] == 0
    # prediction 2's two halves: the false alarms go; the true lines stay (per generator)
    alarms_go = all(still[v] <= n_alarms // 2 for v in one_sided)
    kept = {(v, g): by_gen[(v, g)] >= 0.9 * by_gen[(SHIPPED, g)]
            for v in one_sided for g in SETS}
    # prediction 3: interleaving matters more than the number of blocks, i.e. at least
    # half of the shipped split's line alarms survive 3 and 9 interleaved blocks
    held_3 = min(still["n3"], still["n9"]) >= n_alarms / 2
    named_txt = "; ".join(
        f"generator {g} {by_gen[(SHIPPED, g)]} → {by_gen[('train_first', g)]} and "
        f"{by_gen[('validation_first', g)]} of {n_gen[g]}" for g in SETS)
    lines = [
        "# The slow-line false alarms, checked by varying the blocks' layout and the load", "",
        "Generated by `experiments/block_layout.py` (design and the reading's three "
        "predictions, written before the run, in its docstring). Every healthy and "
        "oscillatory-disturbance recording of the independent sets A–I, diagnosed with its "
        "model YAML under the shipped defaults and each block layout "
        "(`diagnose(..., n_blocks=, block_layout=)`, `stictionbench.diagnosis.blocks`); the "
        "healthy ones also re-made by their generator without its load. Wilson 95 % "
        "intervals; paired changes against the shipped layout with McNemar's exact test. "
        "The sets are the ones the reading was made on, so this checks the reading; it "
        "tunes nothing, and the shipped layout is unchanged.", "",
        f"- The shipped layout (`interleaved`, five blocks) reproduced the stored verdicts "
        f"of `independent_set_*.csv` on {reproduced[0]} of {reproduced[1]} recordings.",
        f"- Healthy loops: {n_h}; oscillatory-disturbance recordings: {n_osc}. A slow loop "
        f"has fewer than {SLOW_DOF} independent in-band validation samples (`band_dof`).",
        "", to_markdown(summary(df)), "",
        f"## The {n_alarms} healthy loops the shipped layout names a line, under each "
        "variant", "", to_markdown(alarms), "",
        "## Reading", "",
        f"- **Prediction 1 (the load)**: without the load {n_alarms - still['no_load']} of "
        f"the {n_alarms} line false alarms go ({gone['no_load']} to `none`); healthy loops "
        f"called a line {fa_line[SHIPPED]} → {fa_line['no_load']} of {n_h}, called "
        f"anything {fa[SHIPPED]} → {fa['no_load']}. "
        + ("Held." if held_1 else "Not held: some survive without the load."),
        f"- **Prediction 2 (interpolation, not forecast)**: of the {n_alarms}, "
        f"{still['train_first']} stay a line when the last two blocks are forecast "
        f"(`train_first`) and {still['validation_first']} when the first two are "
        f"(`validation_first`); healthy loops called a line {fa_line[SHIPPED]} → "
        f"{fa_line['train_first']} and {fa_line['validation_first']}, called anything "
        f"{fa[SHIPPED]} → {fa['train_first']} and {fa['validation_first']}. "
        + ("The false-alarm half held (at most half of them stay). " if alarms_go else
           "The false-alarm half failed (more than half of them stay). ")
        + f"True disturbances named, shipped → one-sided: {named_txt}; the half that true "
        "lines are kept (nine tenths or more) "
        + "; ".join(f"{'held' if kept[(v, g)] else 'failed'} for `{v}` on generator {g}"
                    for g in SETS for v in one_sided)
        + ". Generator C's disturbance wanders in frequency (±3 %) and amplitude (±15 %, "
        "Ornstein–Uhlenbeck processes in its code), generator A's is a fixed sinusoid; "
        "whether the wander is why is prediction 4. `validation_first` judges the record's first "
        "blocks and differs from both other layouts on generator A (see the table); why "
        "is not examined here.",
        f"- **Prediction 3 (number of blocks)**: of the {n_alarms}, {still['n3']} and "
        f"{still['n9']} stay a line with 3 and 9 interleaved blocks (healthy loops called "
        f"a line 3 / 5 / 9 blocks: {fa_line['n3']} / {fa_line[SHIPPED]} / "
        f"{fa_line['n9']}; true disturbances named {named['n3']} / {named[SHIPPED]} / "
        f"{named['n9']} of {n_osc}). "
        + ("Held: at least half of them survive another number of interleaved blocks."
           if held_3 else
           "Not held: fewer than half survive another number of interleaved blocks, so "
           "these recordings show the line false alarms to be the load's wander fitted on "
           "one particular split; they do not single out an interpolation between "
           "training blocks."),
        *_wander_lines(df),
        "- The shipped layout is not changed by this report: the sets are those the "
        "reading came from, and a layout chosen here would be in-sample for them.",
    ]
    if "no_wander" in set(df.variant):
        lines += ["", "## Generator C's disturbances with and without their wander", "",
                  to_markdown(wander_table(df))]
    return "\n".join(lines) + "\n"


def figure(df: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from stictionbench.io import atomic_path

    df = _flags(df)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=False)
    colours = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#7f7f7f")
    for ax, (cls, col, title) in zip(axes, (("none", "fa_line", "healthy loops called a line"),
                                             (LINE, "right", "disturbances named right")),
                                     strict=True):
        vs = VARIANTS if cls == "none" else tuple(LAYOUT_VARIANTS)
        d = df[df["class"] == cls]
        # one row per recording, a column per variant: the bars' denominators
        groups = [d[d.generator == g].pivot_table(index=["set", "name"], columns="variant",
                                                  values=col, aggfunc="first")
                  for g in SETS]
        rate_bars(ax, groups, lambda g, v: int(g[v].astype(bool).sum()),
                  [(v, colours[i], v) for i, v in enumerate(vs)])
        ax.set_xticks(range(len(SETS)), [f"generator {g}" for g in SETS])
        ax.set_title(title)
        ax.set_ylabel("rate")
        ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "keep the stored rows and run only the missing ones",
                           argv)
    stem = OUT / "block_layout"
    todo, stored = cases()
    old = None
    if args.reuse and stem.with_suffix(".csv").exists():
        old = pd.read_csv(stem.with_suffix(".csv"))
        have = set(zip(old.set, old.name, old.variant, strict=True))
        todo = [c for c in todo if (c[1], c[2], c[6]) not in have]
    df = run(one, todo, args.jobs) if todo else pd.DataFrame()
    if len(df):
        df = df.merge(stored, on=["set", "name"], how="left")
    df = pd.concat([old, df]) if old is not None else df
    df = df.sort_values(["generator", "set", "name", "variant"],
                        kind="stable").reset_index(drop=True)
    s = df[df.variant == SHIPPED]
    reproduced = (int((s.predicted == s.stored).sum()), len(s))
    publish(df, report(df, reproduced), stem)
    figure(df, stem.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
