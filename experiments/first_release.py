"""The first release's diagnosis on the independent concealed sets, beside today's.

Issue 10 reports what the first release named on the judged set it was tried on (level 1:
12 of 16, level 2: 7 of 16, both ``none`` recordings answered ``none``). The goals are
judged on a set "made like" that one, which this project does not have. The nine sets of
``make independent`` were drawn by two generators written from the issue's description
without sight of the package. How hard are they against the judged set? The first release
is the only diagnosis scored on both, so it is the anchor: its score on our sets against
its 12 and 7 on the judged set says whether our sets are harder or easier, and today's
diagnosis against the first release on the same recordings measures the change since the
issue on data neither was tuned on (the first release never saw any of these sets; today's
rules were set before sets H and I were drawn, see ``line_confinement.py``).

Method. The package as it was at :data:`FIRST` (the last commit before issue 10 was
filed; its diagnosis code is the same as at the first release's closing note, ``2f5e0bf``)
is taken from git (``git archive``) into ``.cache/first_release/code`` and run as a user
ran it then: ``python -m stictionbench.cli diagnose REC.csv --model M.yaml --json
OUT.json``, one process per recording. The first release read only ``process``,
``controller`` and ``sample_time`` from the model YAML and refused other keys, so the
generators' ``op_range`` is left out of its copy (today's diagnosis recognises the same
range from the data when the key is absent: :func:`stictionbench.op_range.infer_op_range`
gives the YAML's range on all 1728 recordings, so its verdicts do not depend on the key).
Today's verdicts are read from ``reports/concealed/independent_set_X.csv`` (written by
``make independent``). Scores of 16 weigh classes equally (``rates.balanced_score``);
paired comparisons by the exact McNemar test on the recordings one names right and the
other does not.

Run: ``.venv/bin/python experiments/first_release.py [--sets a,b,...] [--jobs 2]
[--first-from CSV]`` (about 7 minutes per set of 192 recordings on 2 cores; verdicts cached
per recording in ``.cache/first_release/``); writes
``reports/concealed/first_release.{md,csv,png}``. The first release's verdicts depend on
the recordings alone, so when only today's diagnosis changed, ``--first-from
reports/concealed/first_release.csv`` (a previous output, copied aside) reads them from
there instead of re-running the first release: every recording must be in it, and where it
holds ``recording_sha256`` (the SHA-256 of the recording's CSV and model YAML, written
since 2026-11-28) the recording must hash the same; the report says where its verdicts
came from and whether they were verified.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import betabinom

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import run  # noqa: E402

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_score, balanced_text, mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: the last commit before issue 10 was filed (the first release's diagnosis)
FIRST = "ca8ced1"
#: what issue 10 reports the first release named on the judged set (of 16, per level)
JUDGED = {1: 12, 2: 7}
#: what the first release named right of the judged set's 2 recordings per class (issue
#: 10's list of misses: level 1, one each of dead time, saturation, oscillatory disturbance
#: and dead band; level 2, both dead times, valve characteristics and oscillatory
#: disturbances, one sensor lag, one stiction, one dead band)
JUDGED_RIGHT = {
    1: {"none": 2, "stiction": 2, "deadband": 1, "sensor_lag": 2, "dead_time": 1,
        "valve_characteristic": 2, "saturation": 1, "oscillatory_disturbance": 1},
    2: {"none": 2, "stiction": 1, "deadband": 1, "sensor_lag": 1, "dead_time": 0,
        "valve_characteristic": 0, "saturation": 2, "oscillatory_disturbance": 0}}
#: recordings per class and level in the judged set (8 classes × 2 per level)
JUDGED_PER_CLASS = 2
#: posterior draws of the projection, and their seed
DRAWS, SEED = 20000, 10
#: the issue's goals (of 16, per level)
GOAL = {1: 15, 2: 12}
#: keys of today's diagnosis JSON that the first release did not write (issue 10 added them)
TODAY_ONLY = ("tests", "noise_model")
#: the model-YAML keys the first release accepted
FIRST_KEYS = ("process", "controller", "sample_time")
#: the generator that drew each set (``Makefile``, target ``independent``)
GENERATOR = {"a": "A", "b": "A", "d": "A", "f": "A", "h": "A",
             "c": "C", "e": "C", "g": "C", "i": "C"}
BLIND = ROOT / ".cache" / "blindgen"
WORK = ROOT / ".cache" / "first_release"
OUT = ROOT / "reports" / "concealed"


def extract(commit: str, dest: Path) -> Path:
    """The package at ``commit`` under ``dest`` (``git archive``, once); returns ``dest``."""
    if not (dest / "stictionbench" / "cli.py").is_file():
        dest.mkdir(parents=True, exist_ok=True)
        arch = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "stictionbench"],
                              capture_output=True, check=False)
        if arch.returncode:
            raise SystemExit(f"first_release: git archive {commit}: "
                             f"{arch.stderr.decode().strip().splitlines()[-1]}")
        subprocess.run(["tar", "-x", "-C", str(dest)], input=arch.stdout, check=True)
    return dest


def first_model(text: str) -> str:
    """A model YAML as the first release could read it: only the top-level blocks it
    knew (:data:`FIRST_KEYS`), every other top-level key and its indented lines left out.

    Examples
    --------
    >>> print(first_model("process: {gain: 1}\\nop_range: [0, 100]\\nsample_time: 1.0\\n"),
    ...       end="")
    process: {gain: 1}
    sample_time: 1.0
    """
    keep, out = True, []
    for line in text.splitlines():
        if line and not line[0].isspace() and not line.startswith("#"):
            keep = line.split(":", 1)[0].strip() in FIRST_KEYS
        if keep:
            out.append(line)
    return "\n".join(out) + "\n"


def diagnose_first(code: str, data: str, work: str, name: str) -> dict:
    """The first release's verdict on ``DATA/NAME.csv`` (cached in ``WORK/NAME.json``)."""
    w, d = Path(work), Path(data)
    js = w / f"{name}.json"
    if not js.is_file():
        model = w / f"{name}.yaml"
        model.write_text(first_model((d / f"{name}.model.yaml").read_text()))
        # -P: the working directory is not put on sys.path, so the package found is the
        # old one on PYTHONPATH, not a checkout of today's in the directory run from
        r = subprocess.run([sys.executable, "-P", "-m", "stictionbench.cli", "diagnose",
                            str(d / f"{name}.csv"), "--model", str(model), "--json", str(js)],
                           env={**os.environ, "PYTHONPATH": code}, capture_output=True,
                           text=True, check=False)
        if r.returncode:
            return {"name": name, "first": "error",
                    "first_error": (r.stderr.strip().splitlines() or ["?"])[-1]}
    out = json.loads(js.read_text())
    if set(out) & set(TODAY_ONLY):
        raise RuntimeError(f"{js}: written by today's diagnosis (keys {sorted(TODAY_ONLY)}), "
                           "not the first release's")
    return {"name": name, "first": out["missing_physics"], "first_error": ""}


def tail_at_least(counts: list[tuple[int, int]], k: int,
                  per_class: int = JUDGED_PER_CLASS) -> float:
    """P(at least ``k`` right) on a set of ``per_class`` recordings per class, for a
    diagnosis that named ``(right, of)`` in each class of another set: each class's rate
    under Jeffreys' prior Beta(1/2, 1/2), so its posterior predictive is beta-binomial
    (Gelman et al., *Bayesian Data Analysis*, 3rd ed., 2013, sect. 2.4), classes
    independent, summed by convolution.

    Examples
    --------
    >>> round(tail_at_least([(50, 100)] * 8, 8), 2)   # about Binomial(16, 0.5) >= 8
    0.6
    >>> round(tail_at_least([(12, 12)] * 8, 16), 2)   # never missed in 12: not certain
    0.55
    """
    dist = np.ones(1)
    for right, of in counts:
        dist = np.convolve(dist, betabinom.pmf(np.arange(per_class + 1), per_class,
                                               right + 0.5, of - right + 0.5))
    return float(dist[k:].sum())


def projected(df: pd.DataFrame, judged_right: dict[str, int],
              per_class: int = JUDGED_PER_CLASS,
              draws: int = DRAWS, seed: int = SEED) -> np.ndarray:
    """Draws of today's score of 16 on the judged set, projected through the first
    release: per class, today's rate on recordings the first release named right and on
    those it missed (measured here, Jeffreys' prior, one posterior draw per class and
    draw), applied to the judged set's recordings the first release named right
    (``judged_right``) and missed. Assumes that, given the first release's outcome and
    the class, a recording of the judged set is as hard for today's diagnosis as one of
    these sets.

    Examples
    --------
    >>> d = pd.DataFrame({"class": ["a"] * 40, "first": ["a"] * 20 + ["x"] * 20,
    ...                   "predicted": ["a"] * 20 + ["x"] * 20})
    >>> round(float(projected(d, {"a": 2}, draws=4000).mean()), 1)  # today right whenever first was
    15.7
    """
    rng = np.random.default_rng(seed)
    total = np.zeros(draws)
    for cls, right in judged_right.items():
        g = df[df["class"] == cls]
        ok = (g["predicted"] == cls).to_numpy()
        hit = (g["first"] == cls).to_numpy()
        for mask, n in ((hit, right), (~hit, per_class - right)):
            k, m = int(ok[mask].sum()), int(mask.sum())
            p = rng.beta(k + 0.5, m - k + 0.5, draws)
            total += rng.binomial(n, p)
    return total * 16 / (per_class * len(judged_right))


def paired(df: pd.DataFrame) -> dict:
    """One row of the comparison: both scores of 16, the false alarms, the discordant
    recordings and their McNemar p-value."""
    ok_now, ok_first = df["predicted"] == df["class"], df["first"] == df["class"]
    none = df["class"] == "none"
    only_now, only_first = int((ok_now & ~ok_first).sum()), int((ok_first & ~ok_now).sum())
    return {"recordings": len(df),
            "today, of 16": balanced_text(ok_now, df["class"]),
            "first release, of 16": balanced_text(ok_first, df["class"]),
            "`none` called physics, today": rate_text(int((~ok_now[none]).sum()),
                                                      int(none.sum())),
            "`none` called physics, first": rate_text(int((~ok_first[none]).sum()),
                                                      int(none.sum())),
            "right only today / only first": f"{only_now} / {only_first}",
            "McNemar p": mcnemar_p(only_now, only_first)}


def recording_sha256(data: Path, name: str) -> str:
    """SHA-256 of a recording's CSV followed by its model YAML: what the first release's
    verdict on it depends on."""
    h = hashlib.sha256((data / f"{name}.csv").read_bytes())
    h.update((data / f"{name}.model.yaml").read_bytes())
    return h.hexdigest()


def stored_first(path: Path, set_: str, hashes: pd.Series) -> tuple[pd.DataFrame, bool]:
    """The first release's verdicts on set ``set_`` read from a previous output CSV (see
    the module's docstring), for the recordings of ``hashes`` (name → their
    :func:`recording_sha256`); returns them and whether every one was verified by hash.
    Raises ``ValueError`` for a recording missing from it or hashing differently."""
    old = pd.read_csv(path, dtype={"first_error": str}, keep_default_na=False)
    old = old[old["set"] == set_].set_index("name")
    names = list(hashes.index)
    missing = sorted(set(names) - set(old.index))
    if missing:
        raise ValueError(f"{path}: set {set_} lacks {len(missing)} recording(s), "
                         f"e.g. {missing[0]}")
    verified = "recording_sha256" in old.columns
    if verified:
        changed = [n for n in names if old.at[n, "recording_sha256"] != hashes[n]]
        if changed:
            raise ValueError(f"{path}: set {set_}, {changed[0]}: the recording differs from "
                             "the one its verdict was made on")
    return old.loc[names, ["first", "first_error"]].reset_index(), verified


def load(sets: list[str], jobs: int, first_from: Path | None = None) -> pd.DataFrame:
    """Today's stored verdicts and the first release's (run, or read from ``first_from``),
    one row per recording; ``df.attrs["first_source"]`` says which."""
    code = None if first_from else str(extract(FIRST, WORK / "code"))
    frames, verified = [], True
    for s in sets:
        data = BLIND / f"set_{s}"
        ours = pd.read_csv(OUT / f"independent_set_{s}.csv",
                           usecols=["name", "level", "class", "predicted"])
        hashes = pd.Series({n: recording_sha256(data, n) for n in ours["name"]})
        if first_from:
            first, ok = stored_first(first_from, s, hashes)
            verified &= ok
        else:
            work = WORK / f"set_{s}"
            work.mkdir(parents=True, exist_ok=True)
            first = run(diagnose_first,
                        [(code, str(data), str(work), n) for n in ours["name"]], jobs)
        first["recording_sha256"] = hashes.reindex(first["name"]).to_numpy()
        df = ours.merge(first, on="name", validate="one_to_one")
        df.insert(0, "set", s)
        df.insert(1, "generator", GENERATOR.get(s, "?"))
        frames.append(df)
    df = pd.concat(frames, ignore_index=True)
    df.attrs["first_source"] = (
        "run here" if not first_from else
        f"read from a previous run's `{first_from.name}` (the first release's verdicts "
        "depend on the recordings alone; "
        + ("every recording verified by its SHA-256)" if verified else
           "that file predates the recordings' hashes: the sets were checked byte-identical "
           "by hand, not by this script)"))
    return df


def report(df: pd.DataFrame) -> str:
    sets = "".join(sorted(df["set"].unique())).upper()
    lines = ["# The first release beside today's diagnosis, on the independent sets", "",
             "Generated by `experiments/first_release.py` (method in its docstring). The "
             f"first release is the package at `{FIRST}`, run as a user ran it then; today's "
             "verdicts are those of `make independent`. Neither was tuned on these sets. "
             f"The first release's verdicts: {df.attrs.get('first_source', 'run here')}. "
             "Scores of 16 weigh classes equally, 95 % intervals.", "",
             "![first release against today](first_release.png)", "",
             f"## Both, per generator and level (sets {', '.join(sets)} pooled)", ""]
    rows = []
    for (gen, lvl), g in df.groupby(["generator", "level"]):
        rows.append({"generator": gen, "level": lvl} | paired(g)
                    | {"first release on the judged set (issue 10)": f"{JUDGED[lvl]} of 16",
                       "goal": f"{GOAL[lvl]} of 16"})
    lines += [to_markdown(pd.DataFrame(rows)), ""]
    j = {lvl: balanced_score(g["first"] == g["class"], g["class"])[0]
         for lvl, g in df.groupby("level")}
    t = {lvl: balanced_score(g["predicted"] == g["class"], g["class"])[0]
         for lvl, g in df.groupby("level")}
    tail = {(gen, lvl): tail_at_least(
        [(int((x["first"] == c).sum()), len(x)) for c, x in g.groupby("class")],
        JUDGED[lvl])
        for (gen, lvl), g in df.groupby(["generator", "level"])}
    lines += ["Reading:", "",
              *[f"- level {lvl}: the first release names {j[lvl]:.1f} of 16 on these sets "
                f"against {JUDGED[lvl]} on the judged set; today's diagnosis names "
                f"{t[lvl]:.1f} of 16 on them. Had the judged set been as hard as these (2 "
                "recordings per class, each class at the first release's rate here, with "
                "its uncertainty: `tail_at_least`), the first release would have named "
                f"{JUDGED[lvl]} or more with probability "
                + ", ".join(f"{tail[(gen, lvl)]:.2g} (generator {gen})"
                            for gen in sorted({k[0] for k in tail}))
                + "." for lvl in sorted(j)],
              _false_alarms(df),
              "- Small probabilities say the judged set is easier than these sets for the "
              "one diagnosis scored on both. By how much cannot be read off 2 recordings "
              "per class, and what is easier for the first release need not be as much "
              "easier for today's.", ""]
    prow = []
    for lvl, g in df.groupby("level"):
        d = projected(g, JUDGED_RIGHT[lvl])
        lo, med, hi = np.percentile(d, [2.5, 50, 97.5])
        prow.append({"level": lvl, "today on these sets, of 16": f"{t[lvl]:.1f}",
                     "projected on the judged set, median [95 %]":
                         f"{med:.1f} [{lo:.1f}, {hi:.1f}]",
                     "P(projected ≥ goal)": f"{float((d >= GOAL[lvl] - 1e-9).mean()):.2g}",
                     "goal": GOAL[lvl]})
    lines += ["## Today's diagnosis projected onto the judged set", "",
              "Per class, today's rate on the recordings of these sets the first release "
              "named right and on those it missed, applied to the judged set's recordings "
              "the first release named right and missed (issue 10 lists its misses: "
              "`JUDGED_RIGHT`); posterior draws with Jeffreys' prior (`projected`, "
              f"{DRAWS} draws, seed {SEED}). It assumes that, given the class and the first "
              "release's outcome, a judged recording is as hard for today's diagnosis as "
              "one of these sets. An estimate, not a measurement.", "",
              to_markdown(pd.DataFrame(prow)), ""]
    rows = [{"set": s.upper(), "generator": GENERATOR.get(s, "?"), "level": lvl} | paired(g)
            for (s, lvl), g in df.groupby(["set", "level"])]
    lines += ["## Set by set", "", to_markdown(pd.DataFrame(rows)), ""]
    crow = []
    for (lvl, cls), g in df.groupby(["level", "class"]):
        crow.append({"level": lvl, "class": cls, "recordings": len(g),
                     "today named": rate_text(int((g["predicted"] == cls).sum()), len(g)),
                     "first release named": rate_text(int((g["first"] == cls).sum()), len(g)),
                     "first release's misses named": ", ".join(
                         f"{k} ×{v}" for k, v in
                         g.loc[g["first"] != cls, "first"].value_counts().items()) or "–"})
    lines += ["## Class by class (all sets)", "", to_markdown(pd.DataFrame(crow)), ""]
    err = df[df["first"] == "error"]
    lines += [f"The first release refused {len(err)} of {len(df)} recordings"
              + (": " + "; ".join(sorted(set(err["first_error"])))[:400] if len(err) else "")
              + ".", ""]
    return "\n".join(lines)


def _false_alarms(df: pd.DataFrame) -> str:
    """One line: healthy recordings called physics by each, paired, all sets pooled."""
    n = df[df["class"] == "none"]
    now, first = n["predicted"] != "none", n["first"] != "none"
    only_now, only_first = int((now & ~first).sum()), int((first & ~now).sum())
    return (f"- `none` called physics, all sets and levels: today "
            f"{rate_text(int(now.sum()), len(n))}, the first release "
            f"{rate_text(int(first.sum()), len(n))}; called physics only by today / only by "
            f"the first release {only_now} / {only_first} (McNemar p = "
            f"{mcnemar_p(only_now, only_first):.2g}).")


def figure(df: pd.DataFrame, path: Path) -> None:
    fig, axes = new_figure(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, (lvl, g) in zip(axes, df.groupby("level"), strict=True):
        groups = list(g.groupby("set"))
        for k, (col, colour, label) in enumerate(
                [("predicted", "tab:blue", "today"), ("first", "tab:grey", "first release")]):
            sc = [balanced_score(x[col] == x["class"], x["class"]) for _, x in groups]
            y = [s[0] for s in sc]
            err = [[s[0] - s[1] for s in sc], [s[2] - s[0] for s in sc]]
            ax.bar([i + (k - 0.5) * 0.38 for i in range(len(groups))], y, 0.38, yerr=err,
                   capsize=3, color=colour, label=label)
        ax.axhline(JUDGED[lvl], color="k", ls="--", lw=1,
                   label="first release on the judged set")
        ax.axhline(GOAL[lvl], color="tab:green", ls=":", lw=1.2, label="goal")
        ax.set_xticks(range(len(groups)),
                      [f"{s.upper()} ({GENERATOR.get(s, '?')})" for s, _ in groups])
        ax.set_title(f"level {lvl}")
        ax.set_xlabel("independent set (generator)")
        ax.set_ylim(0, 16)
    axes[0].set_ylabel("named correctly, of 16")
    axes[1].legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    save_png(fig, path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default=",".join(sorted(GENERATOR)),
                    help="comma-separated set letters (default: all nine)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--first-from", type=Path, default=None,
                    help="a previous first_release.csv to read the first release's verdicts "
                         "from instead of re-running it")
    args = ap.parse_args(argv)
    sets = [s.strip().lower() for s in args.sets.split(",") if s.strip()]
    for s in sets:
        for need in (BLIND / f"set_{s}" / "truth.csv", OUT / f"independent_set_{s}.csv"):
            if not need.is_file():
                print(f"first_release: {need}: no such file (run `make independent`)",
                      file=sys.stderr)
                return 2
    if args.first_from is not None and not args.first_from.is_file():
        print(f"first_release: {args.first_from}: no such file", file=sys.stderr)
        return 2
    try:
        df = load(sets, args.jobs, args.first_from)
    except ValueError as e:
        print(f"first_release: {e}", file=sys.stderr)
        return 2
    with atomic_path(OUT / "first_release.csv") as tmp:
        df.to_csv(tmp, index=False)
    text = report(df)
    write_text(OUT / "first_release.md", text)
    figure(df, OUT / "first_release.png")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
