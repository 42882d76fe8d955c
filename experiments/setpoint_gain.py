"""The set-point gain test (:mod:`stictionbench.diagnosis.gain`) across generator families.

The test measures the loop's gain by instrumental variables (the set point's moves as the
instrument) and compares it with the model's; the diagnosis names
``valve_characteristic`` from it where nothing else was named. Its two settings
(:data:`~stictionbench.diagnosis.gain.GAIN_ALPHA`,
:data:`~stictionbench.diagnosis.gain.GAIN_TOLERANCE`) were set on the healthy loops of
the three tuning families (``experiments/concealed.py``'s); this script shows them there
(in-sample) and reports the same test, unchanged, on the holdout family and on the
independent sets written without sight of the package (out of sample). Per source, class
and level: how often the test flags a gain error (Wilson 95 % intervals), the median
gain ratio and the largest ``|ln ratio|`` of the healthy loops; a figure of every
``|ln ratio|`` against the tolerance.

What a flag means differs by class: for ``valve_characteristic`` it is the detection the
rule exists for; for ``none`` it is a false alarm; for the other classes it is a gain
the other physics also moves (a sensor lag or a sticking valve lowers the in-band
response), and the diagnosis reads it only where it named nothing, so there a miss stays
a miss under another name.

Run: ``.venv/bin/python experiments/setpoint_gain.py [--seeds 4] [--none-seeds 12]
[--holdout-first-seed 21000] [--jobs 2]`` (``make concealed`` runs it after ``make
independent``, whose sets it reads from ``.cache/blindgen``; sets absent are skipped
with a note). Writes ``reports/concealed/setpoint_gain.{md,csv,png}``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import write_job  # noqa: E402
from concealed_families import CLASSES, FAMILIES  # noqa: E402
from concealed_families import make_recording as family_recording  # noqa: E402
from holdout_family import generate as holdout_generate  # noqa: E402

from stictionbench.diagnosis import load_model  # noqa: E402
from stictionbench.diagnosis.diagnose import compare  # noqa: E402
from stictionbench.diagnosis.gain import GAIN_ALPHA, GAIN_TOLERANCE, setpoint_gain  # noqa: E402
from stictionbench.io import atomic_path, read_recording, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
BLIND = ROOT / ".cache" / "blindgen"
#: the independent sets, as ``make independent`` writes them
SETS = ("set_a", "set_b", "set_c", "set_d", "set_e")


def measure(job: tuple[str, str, str, str, int]) -> dict:
    """The test on one recording: ``(source, family, csv, model, level, class)``."""
    source, family, csv, model, level, cls = job
    rec = read_recording(csv, warn=False)
    t = setpoint_gain(compare(rec, load_model(model)))
    return {"source": source, "family": family, "class": cls, "level": level,
            "name": Path(csv).stem, "applicable": t.applicable, "ratio": t.ratio,
            "p_value": t.p_value, "flagged": t.significant,
            "abs_log_ratio": abs(math.log(t.ratio)) if t.ratio > 0 else math.nan,
            "instrument_correlation": t.instrument_correlation}


def jobs_tuning(tmp: Path, seeds: int, none_seeds: int) -> list[tuple]:
    out = []
    for fam in FAMILIES:
        for level in (1, 2):
            for cls in CLASSES:
                for s in range(none_seeds if cls == "none" else seeds):
                    c, sig = family_recording(fam, cls, level, s)
                    j = write_job(c, sig, tmp)
                    out.append(("tuning families (in-sample)", fam, j["csv"], j["model"],
                                level, cls))
    return out


def jobs_holdout(tmp: Path, first: int, seeds: int, none_seeds: int) -> list[tuple]:
    out = []
    for level in (1, 2):
        for cls in CLASSES:
            for s in range(first, first + (none_seeds if cls == "none" else seeds)):
                j = holdout_generate(cls, level, s, tmp)
                out.append(("holdout family", "holdout_sync", j["csv"], j["model"], level,
                            cls))
    return out


def jobs_sets(notes: list[str]) -> list[tuple]:
    out = []
    for s in SETS:
        d = BLIND / s
        if not (d / "truth.csv").exists():
            notes.append(f"- independent {s}: not found in `{d}` (run `make independent`); "
                         "skipped.")
            continue
        t = pd.read_csv(d / "truth.csv")
        for _, r in t.iterrows():
            out.append(("independent sets", s, str(d / f"{r['name']}.csv"),
                        str(d / f"{r['name']}.model.yaml"), int(r["level"]), r["class"]))
    return out


def table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (src, level, cls), g in df.groupby(["source", "level", "class"], sort=False):
        k, n = int(g.flagged.sum()), int(g.applicable.sum())
        rows.append({"source": src, "level": level, "class": cls,
                     "flagged": rate_text(k, n),
                     "median ratio": f"{g.ratio.median():.3f}",
                     "largest |ln ratio|": f"{g.abs_log_ratio.max():.3f}"})
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> Path:
    sources = list(dict.fromkeys(df.source))
    fig, axs = new_figure(1, len(sources), figsize=(5 * len(sources), 4.5), squeeze=False)
    for ax, src in zip(axs[0], sources, strict=True):
        g = df[df.source == src]
        for i, cls in enumerate(CLASSES):
            for level, mk in ((1, "o"), (2, "x")):
                v = g[(g["class"] == cls) & (g.level == level)].abs_log_ratio.dropna()
                ax.scatter(np.full(v.size, i + (0.15 if level == 2 else -0.15)), v,
                           s=10, marker=mk, alpha=0.6,
                           color="C3" if cls == "none" else
                           ("C2" if cls == "valve_characteristic" else "C0"),
                           label=f"level {level}" if i == 0 else None)
        ax.axhline(math.log(GAIN_TOLERANCE), color="k", ls=":",
                   label=f"tolerance ln {GAIN_TOLERANCE:g}")
        ax.set_yscale("symlog", linthresh=0.01)
        ax.set_xticks(range(len(CLASSES)))
        ax.set_xticklabels([c.replace("_", " ") for c in CLASSES], rotation=60, ha="right",
                           fontsize=7)
        ax.set(title=src, ylabel="|ln(gain measured / given)|")
        ax.legend(fontsize=7, loc="upper left")
    return save_png(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--none-seeds", type=int, default=12)
    ap.add_argument("--holdout-first-seed", type=int, default=21000)
    ap.add_argument("--holdout-seeds", type=int, default=6)
    ap.add_argument("--holdout-none-seeds", type=int, default=12)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(OUT))
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    notes: list[str] = []
    with tempfile.TemporaryDirectory() as tmp:
        jobs = (jobs_tuning(Path(tmp), args.seeds, args.none_seeds)
                + jobs_holdout(Path(tmp), args.holdout_first_seed, args.holdout_seeds,
                               args.holdout_none_seeds)
                + jobs_sets(notes))
        with ProcessPoolExecutor(args.jobs) as ex:
            rows = list(tqdm(ex.map(measure, jobs, chunksize=4), total=len(jobs),
                             desc="setpoint gain", unit="rec"))
    df = pd.DataFrame(rows)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "setpoint_gain.csv") as p:
        df.to_csv(p, index=False)
    png = figure(df, out / "setpoint_gain.png")
    healthy = df[df["class"] == "none"]
    lines = [
        "# The set-point gain test across families",
        "",
        "Generated by `experiments/setpoint_gain.py` "
        f"({len(df)} recordings, {time.perf_counter() - t0:.0f} s). The test "
        "(`stictionbench/diagnosis/gain.py`) flags a gain error when the instrumental-"
        f"variable gain differs from the model's at p < {GAIN_ALPHA:g} and by at least "
        f"{GAIN_TOLERANCE:g}× either way; the diagnosis names `valve_characteristic` "
        "from a flag only where it named nothing else.",
        "",
        "Largest `|ln ratio|` of the healthy (`none`) loops, per source (the tolerance is "
        f"ln {GAIN_TOLERANCE:g} = {math.log(GAIN_TOLERANCE):.3f}; the settings were chosen "
        "on the tuning families, in-sample):",
        "",
    ]
    for src, g in healthy.groupby("source", sort=False):
        lines.append(f"- {src}: {g.abs_log_ratio.max():.3f} over {len(g)} loops; flagged "
                     f"{rate_text(int(g.flagged.sum()), len(g))}")
    lines += ["", *notes, "", to_markdown(table(df)), "", f"![]({png.name})", ""]
    write_text(out / "setpoint_gain.md", "\n".join(lines))
    print(f"wrote {out / 'setpoint_gain.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
