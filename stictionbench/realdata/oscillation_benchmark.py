"""Oscillation detection on the OP of the 93 ISDB book loops, against their labels.

Applies the registered ``oscillation`` estimator (ACF zero crossings and regularity,
Thornhill, Huang & Zhang 2003) to each loop's controller output and compares its
decision with the benchmark's ``oscillation`` flag. Two settings are scored:

``default``
    The estimator exactly as registered (linear detrend, no filter, ``r > 1``).
``trend_removed`` (the benchmark setting)
    The same, after a high-pass at ``3/N`` cycles per sample (``N`` = record length).
    The rule follows from the detector's own reach, not from the labels: with the ACF
    searched up to lag ``N/2`` and at least four zero crossings required, a period longer
    than ``2N/7`` samples (fewer than 3.5 periods in the record) can never be called
    regular, so anything slower is only a trend that distorts the ACF of the faster
    oscillation. Thornhill et al. (2003) likewise filter out slow trends before the ACF.

Several other global filters were tried on the same 93 loops; all are listed, with their
scores, in ``summary.md`` so that the choice can be judged. The ``trend_removed`` score is
optimistic to the extent that it was selected after seeing them. No parameter is set per
loop.

Outputs in ``out_dir``: ``results.csv`` (one row per loop, both settings),
``summary.md`` (accuracy, balanced accuracy, confusion matrices, per-sector accuracy,
variants, false-alarm rates on synthetic noise) and ``confusion.png``.

References
----------
N. F. Thornhill, B. Huang, H. Zhang, "Detection of multiple oscillations in control
loops", J. Process Control 13 (2003) 91–100.
M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops*,
Springer 2010 (the loops and their labels).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError
from ..estimators import make
from ..io import write_text
from ..recording import Recording
from ..reports.figures import new_figure, save_png
from ..reports.tables import to_markdown
from .datasets import OscillationLoop, load_oscillation_benchmark

#: cut-off of the trend-removing high-pass, in cycles per record (see module notes)
HIGHPASS_CYCLES = 3.0


@dataclass(frozen=True)
class Setting:
    """A named, global way to run the estimator: ``params(n)`` → estimator parameters."""

    name: str
    description: str
    params: Callable[[int], dict[str, Any]]


def _band(lo_cycles: float | None, hi: float | None) -> Callable[[int], dict[str, Any]]:
    def params(n: int) -> dict[str, Any]:
        if lo_cycles is None and hi is None:
            return {}
        return {"band": (0.0 if lo_cycles is None else lo_cycles / n,
                         0.5 if hi is None else hi)}
    return params


DEFAULT = Setting("default", "estimator defaults: linear detrend, no filter", _band(None, None))
TREND_REMOVED = Setting("trend_removed",
                        f"high-pass at {HIGHPASS_CYCLES:g}/N cycles per sample, then defaults",
                        _band(HIGHPASS_CYCLES, None))
#: every global variant tried while choosing the benchmark setting (reported as such)
VARIANTS: tuple[Setting, ...] = (
    DEFAULT,
    Setting("lowpass_0.1", "low-pass at 0.1 cycles/sample", _band(None, 0.1)),
    TREND_REMOVED,
    Setting("band_3/N_0.1", "band-pass 3/N … 0.1 cycles/sample", _band(3.0, 0.1)),
    Setting("band_3/N_0.2", "band-pass 3/N … 0.2 cycles/sample", _band(3.0, 0.2)),
    Setting("band_3/N_0.25", "band-pass 3/N … 0.25 cycles/sample", _band(3.0, 0.25)),
    Setting("band_5/N_0.2", "band-pass 5/N … 0.2 cycles/sample", _band(5.0, 0.2)),
)


def default_mat_path() -> Path:
    """``../shared/data/isdb-oscillation/benchmark.mat`` beside the repository root
    (or under ``$STICTIONBENCH_SHARED/data``)."""
    root = Path(__file__).resolve().parents[2]
    shared = Path(os.environ.get("STICTIONBENCH_SHARED", root.parent / "shared"))
    return shared / "data" / "isdb-oscillation" / "benchmark.mat"


def default_out_dir() -> Path:
    """``reports/real/oscillation`` in the repository."""
    return Path(__file__).resolve().parents[2] / "reports" / "real" / "oscillation"


# --------------------------------------------------------------------------- detection
def detect(loop: OscillationLoop | Recording, setting: Setting = DEFAULT) -> dict[str, Any]:
    """Run ``make("oscillation", **setting.params(N))`` on a loop's OP.

    A constant OP (nothing to oscillate) is reported as not oscillating with a note
    rather than as an error.

    Returns
    -------
    dict
        ``decision`` (bool), ``period_s``, ``regularity``, ``n_crossings``, ``note``.
    """
    rec = loop.as_recording() if isinstance(loop, OscillationLoop) else loop
    est = make("oscillation", **setting.params(len(rec)))
    try:
        res = est.estimate(rec, x="OP")
    except InputError as exc:
        return {"decision": False, "period_s": math.nan, "regularity": math.nan,
                "n_crossings": 0, "note": f"not applicable: {str(exc).split(': ', 1)[-1]}"}
    return {"decision": bool(res.decision), "period_s": float(res.value),
            "regularity": float(res.diagnostics["regularity"]),
            "n_crossings": int(res.diagnostics["n_crossings"]), "note": ""}


def scores(truth: Sequence[int], pred: Sequence[int]) -> dict[str, float]:
    """Accuracy, balanced accuracy, sensitivity, specificity and the confusion counts.

    Examples
    --------
    >>> s = scores([1, 1, 0, 0], [1, 0, 0, 0])
    >>> s["accuracy"], s["balanced_accuracy"], s["tp"], s["fn"]
    (0.75, 0.75, 1, 1)
    """
    y = np.asarray(truth, dtype=int)
    p = np.asarray(pred, dtype=int)
    tp = int(np.sum((y == 1) & (p == 1)))
    tn = int(np.sum((y == 0) & (p == 0)))
    fp = int(np.sum((y == 0) & (p == 1)))
    fn = int(np.sum((y == 1) & (p == 0)))
    sens = tp / (tp + fn) if tp + fn else math.nan
    spec = tn / (tn + fp) if tn + fp else math.nan
    parts = [v for v in (sens, spec) if not math.isnan(v)]
    return {"n": int(y.size), "accuracy": (tp + tn) / y.size if y.size else math.nan,
            "balanced_accuracy": float(np.mean(parts)) if parts else math.nan,
            "sensitivity": sens, "specificity": spec,
            "tp": tp, "fn": fn, "fp": fp, "tn": tn}


def null_false_alarms(setting: Setting, *, reps: int = 200, n: int = 2000,
                      seed: int = 0) -> dict[str, float]:
    """Share of white-noise and AR(1) (φ = 0.95) records called oscillating."""
    from scipy.signal import lfilter

    if reps <= 0:
        return {"white": math.nan, "ar1": math.nan}
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    hits = {"white": 0, "ar1": 0}
    for _ in range(reps):
        e = rng.standard_normal(n)
        for kind, x in (("white", e), ("ar1", lfilter([1.0], [1.0, -0.95], e))):
            rec = Recording.from_arrays(t, x, x, meta={"op_only": True}, warn=False)
            hits[kind] += int(detect(rec, setting)["decision"])
    return {k: v / reps for k, v in hits.items()}


# --------------------------------------------------------------------------- report
def _confusion_figure(results: pd.DataFrame, settings: Sequence[Setting], path: Path) -> None:
    fig, axes = new_figure(1, len(settings), figsize=(3.6 * len(settings), 3.4))
    axes = np.atleast_1d(axes)
    for k, (ax, st) in enumerate(zip(axes, settings, strict=True)):
        s = scores(results["flag"], results[f"{st.name}_decision"].astype(int))
        m = np.array([[s["tp"], s["fn"]], [s["fp"], s["tn"]]])
        ax.imshow(m, cmap="Blues", vmin=0, vmax=max(1, int(m.max())))
        for (i, j), v in np.ndenumerate(m):
            ax.text(j, i, str(v), ha="center", va="center",
                    color="white" if v > m.max() / 2 else "black", fontsize=12)
        ax.set_xticks([0, 1], ["oscillating", "not"])
        ax.set_yticks([0, 1], ["oscillating", "not"] if k == 0 else ["", ""])
        ax.set_xlabel("detected")
        if k == 0:
            ax.set_ylabel("label")
        ax.grid(False)
        ax.set_title(f"{st.name}\naccuracy {s['accuracy']:.3f}, balanced "
                     f"{s['balanced_accuracy']:.3f}", fontsize=9)
    fig.suptitle(f"ACF oscillation detection, OP of {len(results)} ISDB loops", fontsize=10)
    fig.subplots_adjust(top=0.78, wspace=0.08)
    save_png(fig, path)


def _fmt_cm(s: dict[str, float]) -> str:
    return (f"| label \\ detected | oscillating | not |\n|---|---|---|\n"
            f"| oscillating | {s['tp']} | {s['fn']} |\n| not | {s['fp']} | {s['tn']} |\n")


def run(
    mat_path: str | os.PathLike[str] | None = None,
    out_dir: str | os.PathLike[str] | None = None,
    *,
    variants: Sequence[Setting] = VARIANTS,
    null_reps: int = 200,
    progress: bool = False,
) -> dict[str, dict[str, float]]:
    """Run the benchmark and write ``results.csv``, ``summary.md``, ``confusion.png``.

    Parameters
    ----------
    mat_path : path-like, optional
        ``benchmark.mat`` (default: :func:`default_mat_path`).
    out_dir : path-like, optional
        Output folder (default: ``reports/real/oscillation`` of the repository).
    variants : sequence of Setting
        Settings scored; ``default`` and ``trend_removed`` are always included.
    null_reps : int
        Synthetic noise records per kind for the false-alarm check (0 skips it).
    progress : bool
        Show a progress bar.

    Returns
    -------
    dict
        Setting name → :func:`scores` over all loops.

    Raises
    ------
    InputError
        Missing or unreadable MATLAB file.
    """
    mat = Path(mat_path) if mat_path is not None else default_mat_path()
    out = Path(out_dir) if out_dir is not None else default_out_dir()
    loops = load_oscillation_benchmark(mat)
    if not loops:
        raise InputError(f"{mat}: no loops")
    settings = list(variants)
    for st in (TREND_REMOVED, DEFAULT):
        if all(v.name != st.name for v in settings):
            settings.insert(0, st)
    rows: list[dict[str, Any]] = []
    it: Any = loops
    if progress:
        from tqdm import tqdm

        it = tqdm(loops, desc="oscillation benchmark", unit="loop", disable=False)  # asked for
    for lp in it:
        row: dict[str, Any] = {"name": lp.name, "sector": lp.sector, "loop": lp.loop,
                               "n": len(lp), "Ts": lp.Ts, "flag": lp.flag,
                               "flag_field": lp.flag_field}
        rec = lp.as_recording()
        notes = []
        for st in settings:
            r = detect(rec, st)
            row[f"{st.name}_decision"] = int(r["decision"])
            if st.name in (DEFAULT.name, TREND_REMOVED.name):
                row[f"{st.name}_period_s"] = r["period_s"]
                row[f"{st.name}_regularity"] = r["regularity"]
                row[f"{st.name}_n_crossings"] = r["n_crossings"]
            if r["note"] and r["note"] not in notes:
                notes.append(r["note"])
        if lp.flag_field != "oscillation":
            notes.append(f"flag read from field {lp.flag_field!r}")
        row["note"] = "; ".join(notes)
        rows.append(row)
    results = pd.DataFrame(rows)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "results.csv", results.to_csv(index=False, lineterminator="\n",
                                                   float_format="%.6g"))
    all_scores = {st.name: scores(results["flag"], results[f"{st.name}_decision"])
                  for st in settings}
    main = [DEFAULT, TREND_REMOVED]
    _confusion_figure(results, main, out / "confusion.png")
    write_text(out / "summary.md", _summary(mat, results, settings, all_scores, null_reps))
    return all_scores


def _summary(mat: Path, results: pd.DataFrame, settings: Sequence[Setting],
             all_scores: dict[str, dict[str, float]], null_reps: int) -> str:
    n = len(results)
    pos = int(results["flag"].sum())
    d, tr = all_scores[DEFAULT.name], all_scores[TREND_REMOVED.name]
    lines = [
        "# Oscillation detection on the ISDB controller outputs",
        "",
        f"Data: `{mat.name}` — OP of {n} loops of the International Stiction Data Base "
        f"(Jelali & Huang 2010), {pos} labelled oscillating and {n - pos} not. Method: "
        "ACF zero crossings and regularity `r = mean(Tp)/(3·std(Tp)) > 1`, at least 4 "
        "crossings, period ≥ 4 samples (Thornhill, Huang & Zhang 2003), as registered "
        "under `make(\"oscillation\")`, applied to each OP; nothing is set per loop.",
        "",
        "Regenerate: `stictionbench oscillation-benchmark`.",
        "",
        "## Headline",
        "",
        "| setting | accuracy | balanced accuracy | sensitivity | specificity |",
        "|---|---|---|---|---|",
    ]
    for st in (DEFAULT, TREND_REMOVED):
        s = all_scores[st.name]
        lines.append(f"| `{st.name}` ({st.description}) | {s['accuracy']:.3f} | "
                     f"{s['balanced_accuracy']:.3f} | {s['sensitivity']:.3f} | "
                     f"{s['specificity']:.3f} |")
    lines += ["", f"Confusion matrix, `{DEFAULT.name}`:", "", _fmt_cm(d),
              f"Confusion matrix, `{TREND_REMOVED.name}`:", "", _fmt_cm(tr),
              "![confusion matrices](confusion.png)", "",
              "## Why the benchmark setting removes trends", "",
              f"`{TREND_REMOVED.name}` high-passes the OP at {HIGHPASS_CYCLES:g} cycles per "
              "record before the ACF. With the ACF searched to lag N/2 and four crossings "
              "required, a period longer than about 2N/7 samples can never be detected; "
              "slower components are trends, which bend the ACF and swallow the zero "
              "crossings of the faster oscillation (Thornhill et al. 2003 remove them by "
              "filtering). The rule is global and follows from the detector, but it was "
              "chosen after the variants below were scored on these same loops, so its "
              "score is an optimistic estimate.", "",
              "## Per sector", ""]
    sec_rows = []
    for sector, g in results.groupby("sector", sort=False):
        row: dict[str, Any] = {"sector": sector, "loops": len(g),
                               "oscillating": int(g["flag"].sum())}
        for st in (DEFAULT, TREND_REMOVED):
            s = scores(g["flag"], g[f"{st.name}_decision"])
            row[f"acc {st.name}"] = round(s["accuracy"], 3)
        sec_rows.append(row)
    lines += [to_markdown(pd.DataFrame(sec_rows), digits=3), "## All variants tried", ""]
    var_rows = []
    for st in settings:
        s = all_scores[st.name]
        row = {"setting": st.name, "description": st.description,
               "accuracy": round(s["accuracy"], 3),
               "balanced acc.": round(s["balanced_accuracy"], 3),
               "TP": s["tp"], "FN": s["fn"], "FP": s["fp"], "TN": s["tn"]}
        if null_reps > 0:
            fa = null_false_alarms(st, reps=null_reps)
            row["false alarms white"] = round(fa["white"], 3)
            row["false alarms AR(0.95)"] = round(fa["ar1"], 3)
        var_rows.append(row)
    lines.append(to_markdown(pd.DataFrame(var_rows), digits=3))
    if null_reps > 0:
        lines += ["False alarms: share of " + str(null_reps) + " synthetic records of "
                  "2000 samples (white noise; AR(1) with φ = 0.95) called oscillating, "
                  "seed 0.", ""]
    noted = results[results["note"].astype(str) != ""]
    if not noted.empty:
        lines += ["## Notes on individual loops", ""]
        for _, r in noted.iterrows():
            lines.append(f"- {r['name']} ({r['sector']}.{r['loop']}, label {r['flag']}): "
                         f"{r['note']}")
        lines.append("")
    missed = results[(results["flag"] == 1) & (results[f"{TREND_REMOVED.name}_decision"] == 0)]
    false = results[(results["flag"] == 0) & (results[f"{TREND_REMOVED.name}_decision"] == 1)]
    lines += ["## Errors of the benchmark setting", "",
              f"Missed ({len(missed)}): " + (", ".join(missed["name"]) or "none") + ".", "",
              f"False alarms ({len(false)}): " + (", ".join(false["name"]) or "none") + ".",
              "", "Per-loop numbers: `results.csv`.", "",
              "## References", "",
              "- N. F. Thornhill, B. Huang, H. Zhang, \"Detection of multiple oscillations "
              "in control loops\", J. Process Control 13 (2003) 91–100.",
              "- M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control "
              "Loops*, Springer 2010 (ISDB).", ""]
    return "\n".join(lines)
