"""The diagnosis with an ARMA noise model against the shipped AR one, scored on the sets
A–I and on two fresh sets drawn for it, against a criterion written before either run.

Why: issue 10 asks for "a noise model on the output error (ARMA, with an integrated option
for drifting loads)". The package's noise model is AR / integrated AR of order up to 12 by
BIC (:mod:`stictionbench.diagnosis.noise`, family ``"ar"``).
``reports/concealed/noise_model_family.md`` found, on 264 healthy loops, an ARMA model's
BIC lower by more than 10 on 57 % of them and the Ljung–Box test rejecting white validation
innovations on 34 % under ARMA against 63 % under AR; it did not find the false alarms
among the loops with the most correlated innovations. This run puts the ARMA family
(``noise_family="arma"``: the AR model and ARMA / ARIMA (p, q) ∈ {(1,1), (2,1), (1,2), (2,2)},
:func:`stictionbench.diagnosis.noise.fit_noise_model`) into every noise model the
diagnosis fits (the prediction-error refit, the valve identification, the likelihood
tests, the set-point gain test) and asks whether the verdicts get better.

Recordings: every recording of the independent sets A–I (1728; their ``ar`` verdicts are
the stored ones, ``independent_set_*.csv``; the diagnosis's thresholds were set on and
checked against these sets, so they are in-sample for the thresholds, not for this
change) and two fresh sets drawn for this run, generator A from seed 79000 and generator
C from seed 81000, 12 recordings per class and level each (384, out of sample), run under
both families (the time ratio is measured there, in the same run).

**Prediction, written before the run.** The healthy loops' validation innovations are
whiter under ARMA (Ljung–Box at 20 lags rejecting at 5 % less often), as
``noise_model_family.py`` measured outside the diagnosis.

**Criterion, written before the run.** ARMA becomes the default only if on the fresh sets
pooled (1) no more healthy loops are called physics than under AR, (2) the score of 16 at
each level is not lower than AR's by more than 0.25, (3) it gains something: fewer healthy
loops called physics, or a level's score higher by at least 0.25; (4) (1) and (2) also
hold on sets A–I; and (5) a diagnosis under it stays within the issue's 2 s per
3000-sample recording (median on the fresh sets). Otherwise it is not adopted, and the
report says which part failed.

Run: ``.venv/bin/python experiments/arma_diagnosis.py [--jobs 2] [--reuse]`` after ``make
independent`` (the sets in ``.cache/blindgen``; the fresh sets are generated here);
writes ``reports/concealed/arma_diagnosis.{md,csv}`` (about 40 minutes on 2 cores).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import jobs_reuse_args, publish, run  # noqa: E402
from verdict_scores import (  # noqa: E402
    DATA,
    PER_CLASS,
    draw_sets,
    level_score,
    level_scores,
    per_class_rates,
)

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
SETS = {"A": ("a", "b", "d", "f", "h"), "C": ("c", "e", "g", "i")}
#: the criterion's largest loss, and smallest gain, of score of 16 at a level
MAX_LOSS = 0.25
MIN_GAIN = 0.25
#: the issue's time per 3000-sample recording
MAX_SECONDS = 2.0
#: Ljung–Box level of the whiteness prediction
LB_ALPHA = 0.05
#: every variant's ``diagnose`` keywords (``ar`` is the shipped diagnosis)
KWARGS: dict[str, dict[str, str]] = {"ar": {}, "arma": {"noise_family": "arma"},
                                     "arma_tests": {"test_noise_family": "arma"}}


@dataclass(frozen=True)
class Design:
    """One comparison of a variant against ``ar``: its name in the CSV's ``family``
    column, its label in the report, the fresh sets drawn for it (set → generator
    folder, first seed), its outputs' stem, the report's title and what the variant is."""

    alt: str
    label: str
    fresh: dict[str, tuple[str, int]]
    stem: str
    title: str
    what: str

    @property
    def families(self) -> tuple[str, str]:
        return ("ar", self.alt)


ARMA = Design("arma", "ARMA",
              {"arma_a": ("blind_generator", 79000), "arma_c": ("blind_generator_c", 81000)},
              "arma_diagnosis", "The diagnosis with an ARMA noise model",
              "that model and ARMA / ARIMA models of low order by BIC in every noise model "
              "the diagnosis fits")
#: the fresh sets and the two families of :data:`ARMA`
FRESH, FAMILIES = ARMA.fresh, ARMA.families


def fresh_sets(d: Design = ARMA) -> None:
    """Write the design's fresh sets with their generators (byte-identical files)."""
    draw_sets(d.fresh, PER_CLASS)


def one(part: str, gen: str, set_: str, name: str, cls: str, level: int,
        family: str) -> dict:
    """One recording diagnosed with its model YAML under the variant ``family``
    (:data:`KWARGS`)."""
    src = DATA / (set_ if part == "fresh" else f"set_{set_}")
    rec = read_recording(str(src / f"{name}.csv"), warn=False)
    t0 = time.perf_counter()
    r = diagnose(rec, load_model(src / f"{name}.model.yaml"), **KWARGS[family])
    nm = r.noise_model
    return {"part": part, "generator": gen, "set": set_, "name": name, "class": cls,
            "level": level, "family": family, "predicted": r.missing_physics,
            "seconds": time.perf_counter() - t0, "noise": nm.get("family"),
            "ar_order": nm.get("ar_order"), "ma_order": nm.get("ma_order"),
            "whiteness_p": r.tests.get("whiteness", {}).get("p_value")}


def cases(d: Design = ARMA) -> tuple[list[tuple], pd.DataFrame]:
    """Every job, and the stored AR verdicts of sets A–I."""
    todo, stored = [], []
    for gen, sets in SETS.items():
        for s in sets:
            t = pd.read_csv(OUT / f"independent_set_{s}.csv")
            stored.append(pd.DataFrame({"part": "A–I", "generator": gen, "set": s,
                                        "name": t["name"], "class": t["class"],
                                        "level": t.level, "family": "ar",
                                        "predicted": t.predicted}))
            todo += [("A–I", gen, s, r["name"], r["class"], int(r.level), d.alt)
                     for _, r in t.iterrows()]
    for s, (folder, _) in d.fresh.items():
        gen = "A" if folder == "blind_generator" else "C"
        t = pd.read_csv(DATA / s / "truth.csv")
        todo += [("fresh", gen, s, r["name"], r["class"], int(r.level), f)
                 for _, r in t.iterrows() for f in d.families]
    return todo, pd.concat(stored, ignore_index=True)


def verdicts(df: pd.DataFrame, d: Design = ARMA) -> pd.DataFrame:
    """One row per recording: each family's verdict."""
    w = df.pivot_table(index=["part", "generator", "set", "name", "class", "level"],
                       columns="family", values="predicted", aggfunc="first").reset_index()
    return w.dropna(subset=list(d.families))


def scores(w: pd.DataFrame, d: Design = ARMA) -> pd.DataFrame:
    """Per part, generator and level: each family's score of 16 and healthy loops called
    physics, and the paired changes."""
    return level_scores(w, d.families, d.alt, "ar", f"right only under {d.label} / only AR")


def per_class(w: pd.DataFrame, d: Design = ARMA) -> pd.DataFrame:
    """Named right per class and level, AR against the variant, each part pooled."""
    return per_class_rates(w, d.families)


def _healthy_physics(g: pd.DataFrame, family: str) -> int:
    return int((g[g["class"] == "none"][family] != "none").sum())


def criterion(w: pd.DataFrame, seconds: float,
              d: Design = ARMA) -> list[tuple[str, bool, str]]:
    """The five parts of the criterion: (what, met, the numbers)."""
    out = []
    alt = d.alt
    for part, label in (("fresh", "fresh sets"), ("A–I", "sets A–I")):
        g = w[w.part == part]
        n_h = int((g["class"] == "none").sum())
        fa = {f: _healthy_physics(g, f) for f in d.families}
        sc = {(f, lv): level_score(g, f, lv) for f in d.families for lv in (1, 2)}
        numbers = ", ".join(f"level {lv} {sc['ar', lv]:.2f} → {sc[alt, lv]:.2f}"
                            for lv in (1, 2))
        out.append((f"{label}: no more healthy loops called physics",
                    fa[alt] <= fa["ar"], f"{fa['ar']} → {fa[alt]} of {n_h}"))
        out.append((f"{label}: score of 16 lost at most {MAX_LOSS} at each level",
                    all(sc["ar", lv] - sc[alt, lv] <= MAX_LOSS for lv in (1, 2)),
                    numbers))
        if part == "fresh":
            gain = fa[alt] < fa["ar"] or any(
                sc[alt, lv] - sc["ar", lv] >= MIN_GAIN for lv in (1, 2))
            out.append((f"{label}: a gain (fewer healthy loops called physics, or a "
                        f"level's score up by {MIN_GAIN})", gain, numbers))
    out.append((f"a diagnosis under {d.label} within {MAX_SECONDS:g} s (median)",
                seconds <= MAX_SECONDS, f"{seconds:.2f} s"))
    return out


def whiteness(df: pd.DataFrame, d: Design = ARMA) -> pd.DataFrame:
    """The prediction: healthy fresh loops whose validation innovations Ljung–Box rejects
    at :data:`LB_ALPHA`, and the noise models chosen, per family."""
    rows = []
    h = df[(df.part == "fresh") & (df["class"] == "none")]
    for f in d.families:
        g = h[h.family == f]
        rows.append({"family": f, "healthy loops": len(g),
                     "whiteness rejected": rate_text(int((g.whiteness_p < LB_ALPHA).sum()),
                                                     len(g)),
                     "median p": f"{g.whiteness_p.median():.3g}",
                     "noise models chosen": ", ".join(
                         f"{k} {v}" for k, v in g.noise.value_counts().items())})
    return pd.DataFrame(rows)


def report(df: pd.DataFrame, d: Design = ARMA) -> str:
    alt = d.alt
    w = verdicts(df, d)
    fresh = df[df.part == "fresh"]
    sec = {f: float(fresh[fresh.family == f].seconds.median()) for f in d.families}
    crit = criterion(w, sec[alt], d)
    adopted = all(ok for _, ok, _ in crit)
    white = whiteness(df, d)
    rej = {r["family"]: r["whiteness rejected"] for _, r in white.iterrows()}
    h = fresh[fresh["class"] == "none"]
    n_rej = {f: int((h[h.family == f].whiteness_p < LB_ALPHA).sum()) for f in d.families}
    lines = [
        f"# {d.title}", "",
        f"Generated by `experiments/{d.stem}.py` (the change, the recordings, the "
        "prediction and the criterion, written before the run, in its docstring). **ar**: "
        f"the shipped noise model (AR / integrated AR by BIC); **{alt}**: {d.what}. "
        "Sets A–I carry the stored `ar` verdicts (in-sample for the diagnosis's "
        "thresholds); the two fresh sets were drawn for this run and diagnosed under "
        "both. Scores of 16 weigh the eight classes equally (95 % intervals); Wilson 95 % "
        "intervals; McNemar's exact test on the recordings whose verdict changed.", "",
        f"- Recordings: {int((w.part == 'A–I').sum())} of sets A–I, "
        f"{int((w.part == 'fresh').sum())} fresh.",
        f"- Time per recording on the fresh sets (median, same run): {sec['ar']:.2f} s "
        f"under AR, {sec[alt]:.2f} s under {d.label} (ratio "
        f"{sec[alt] / max(sec['ar'], 1e-9):.2f}).", "",
        to_markdown(scores(w, d)), "",
        "## The prediction: whiter innovations", "",
        to_markdown(white), "",
        ("Held" if n_rej[alt] < n_rej["ar"] else "Not held")
        + f": Ljung–Box rejected the healthy loops' validation innovations on "
        f"{rej['ar']} under AR and {rej[alt]} under {d.label}.", "",
        "## The criterion", "",
        to_markdown(pd.DataFrame([{"part": what, "met": "yes" if ok else "no",
                                   "measured": text} for what, ok, text in crit])), "",
        ("**Every part met.** Whether it became the default: `docs/diagnosis.md`."
         if adopted else
         "**Not adopted**: " + "; ".join(what for what, ok, _ in crit if not ok)
         + " failed. The shipped noise model is unchanged."), "",
        "## Per class", "", to_markdown(per_class(w, d)), "",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None, d: Design = ARMA, doc: str | None = None) -> int:
    args = jobs_reuse_args(doc or __doc__, "re-make the report from the stored CSV", argv)
    stem = OUT / d.stem
    if args.reuse and stem.with_suffix(".csv").exists():
        df = pd.read_csv(stem.with_suffix(".csv"))
    else:
        fresh_sets(d)
        todo, stored = cases(d)
        df = pd.concat([stored, run(one, todo, args.jobs)], ignore_index=True)
        df = df.sort_values(["part", "generator", "set", "name", "family"],
                            kind="stable").reset_index(drop=True)
    publish(df, report(df, d), stem)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
