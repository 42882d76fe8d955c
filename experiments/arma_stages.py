"""Which stage's ARMA noise model calls the extra healthy loops faulty? A follow-up of
``arma_diagnosis.py``, on its healthy loops, varying where the ARMA family is used.

``arma_diagnosis.py`` found that ``diagnose(..., noise_family="arma")`` calls more healthy
loops physics than the shipped AR family (fresh sets 3 → 8 of 48, sets A–I 22 → 30 of
216), although it whitens their validation innovations. The diagnosis fits a noise model
in four places: the likelihood tests (:func:`stictionbench.diagnosis.evidence.validate`),
the prediction-error refit of every hypothesis (``diagnose._prediction_error_refit``), the
closed-loop valve identification (:func:`stictionbench.diagnosis.hammerstein.fit_hammerstein`)
and the set-point gain test (:mod:`stictionbench.diagnosis.gain`). Here the 264 healthy
(``none``) recordings of that run are diagnosed again under

- ``tests_only``: ARMA in the likelihood tests, AR everywhere else;
- ``all_but_tests``: ARMA in the refit, the valve identification and the gain test, AR in
  the likelihood tests;

beside the stored ``ar`` and ``arma`` verdicts. The first run forced the other stages'
``fit_noise_model`` to the AR family by patching; it is now run with ``diagnose``'s own
``noise_family`` (the fits) and ``test_noise_family`` (the tests), added after it, which
give the same verdicts (the stored CSV re-made byte-identical).

**Prediction, written before the run** (it follows from 9 of the 24 extra false alarms
ending with an AR model in their tests under ``arma``, so their tests were not what
changed): ``all_but_tests`` keeps more of the extra false alarms than ``tests_only``
adds. This run is exploratory: it uses the loops whose verdicts prompted it.

Run: ``.venv/bin/python experiments/arma_stages.py [--jobs 2] [--reuse]`` after
``arma_diagnosis.py``; writes ``reports/concealed/arma_stages.{md,csv}`` (about 6 minutes on
2 cores).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import arma_diagnosis as ad  # noqa: E402
from fresh_recordings import jobs_reuse_args, publish, stored_or_run  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: variant → its ``diagnose`` keywords: where the ARMA family is kept
VARIANTS = {"tests_only": {"noise_family": "ar", "test_noise_family": "arma"},
            "all_but_tests": {"noise_family": "arma", "test_noise_family": "ar"}}
ORDER = ("ar", "tests_only", "all_but_tests", "arma")


def one(part: str, gen: str, set_: str, name: str, level: int, variant: str) -> dict:
    """One healthy recording diagnosed under ``VARIANTS[variant]``."""
    src = ad.DATA / (set_ if part == "fresh" else f"set_{set_}")
    rec = read_recording(str(src / f"{name}.csv"), warn=False)
    d = diagnose(rec, load_model(src / f"{name}.model.yaml"), **VARIANTS[variant])
    return {"part": part, "generator": gen, "set": set_, "name": name, "level": level,
            "variant": variant, "predicted": d.missing_physics}


def healthy() -> pd.DataFrame:
    """The healthy recordings of ``arma_diagnosis.csv``, one row per loop and family."""
    df = pd.read_csv(OUT / "arma_diagnosis.csv")
    h = df[df["class"] == "none"]
    return h[["part", "generator", "set", "name", "level", "family", "predicted"]].rename(
        columns={"family": "variant"})


def cases() -> list[tuple]:
    h = healthy()
    loops = h.drop_duplicates(["part", "set", "name"])
    return [(r.part, r.generator, r.set, r["name"], int(r.level), v)
            for _, r in loops.iterrows() for v in VARIANTS]


def table(df: pd.DataFrame) -> pd.DataFrame:
    """Healthy loops called physics per variant and part, and the loops the ``arma`` run
    added (called physics under ``arma``, not under ``ar``) that each variant keeps."""
    w = df.pivot_table(index=["part", "set", "name"], columns="variant",
                       values="predicted", aggfunc="first").dropna()
    added = (w["arma"] != "none") & (w["ar"] == "none")
    rows = []
    for part, g in [*w.groupby(level="part"), ("both", w)]:
        a = added.loc[g.index]
        row = {"part": part, "healthy loops": len(g)}
        for v in ORDER:
            row[f"{v}: called physics"] = rate_text(int((g[v] != "none").sum()), len(g))
        for v in VARIANTS:
            row[f"{v}: keeps of the added"] = f"{int((g[v][a] != 'none').sum())} of {int(a.sum())}"
        rows.append(row)
    return pd.DataFrame(rows)


def report(df: pd.DataFrame) -> str:
    w = df.pivot_table(index=["part", "set", "name"], columns="variant",
                       values="predicted", aggfunc="first").dropna()
    added = (w["arma"] != "none") & (w["ar"] == "none")
    keep = {v: int((w[v][added] != "none").sum()) for v in VARIANTS}
    fa = {v: w[v] != "none" for v in ORDER}
    lines = [
        "# Which stage's ARMA noise model calls healthy loops faulty", "",
        "Generated by `experiments/arma_stages.py` (the variants and the prediction, written "
        "before the run, in its docstring; exploratory: these are the loops whose "
        "verdicts prompted it). The 264 healthy recordings of "
        "[arma_diagnosis.md](arma_diagnosis.md) under `diagnose(..., noise_family=\"arma\")` "
        "with the ARMA family kept only in the likelihood tests (`tests_only`) or everywhere "
        "but there (`all_but_tests`), beside that run's `ar` and `arma` verdicts. Wilson "
        "95 % intervals.", "",
        to_markdown(table(df)), "",
        f"- Of the {int(added.sum())} healthy loops `arma` called physics and `ar` did not, "
        f"`tests_only` keeps {keep['tests_only']} and `all_but_tests` {keep['all_but_tests']}.",
    ]
    for v in VARIANTS:
        a = int((fa[v] & ~fa["ar"]).sum())
        b = int((fa["ar"] & ~fa[v]).sum())
        lines.append(f"- `{v}` against `ar`: {a} loops called physics only under `{v}`, {b} "
                     f"only under `ar` (McNemar p = {mcnemar_p(a, b):.2g}).")
    held = keep["all_but_tests"] > keep["tests_only"]
    lines += ["", ("**Prediction held**" if held else "**Prediction not held**")
              + f": `all_but_tests` keeps {keep['all_but_tests']}, `tests_only` "
              f"{keep['tests_only']} of the {int(added.sum())}.", ""]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "re-make the report from the stored CSV", argv)
    stem = OUT / "arma_stages"
    runs = stored_or_run(stem, args.reuse, one, cases, args.jobs,
                         ["part", "set", "name", "variant"])
    if args.reuse:
        runs = runs[runs.variant.isin(list(VARIANTS))]
    df = pd.concat([healthy(), runs], ignore_index=True)
    publish(runs, report(df), stem)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
