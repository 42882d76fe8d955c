"""Concealed-data benchmark of ``stictionbench diagnose``: three generator families,
thresholds tuned on some families and reported on the family left out.

Every recording is written as a CSV with only ``t, SP, PV, OP`` (1 s, 3000 s) plus the
user's nominal-model YAML (the true FOPDT and PI), read back and diagnosed blind through
the same code path as ``stictionbench diagnose REC.csv --model REC.yaml``. The generator
families (:mod:`concealed_families`) differ in simulator code path, valve model, controller
rate, noise colour and quantisation, and load; one of them shares no code with the
simulator or the fitter.

Thresholds. The decision rule has two thresholds, ``alpha`` (the level of the
likelihood-ratio tests) and ``min_improvement`` (validation NRMSE). Each recording is
diagnosed once; its evidence (every hypothesis's LR p-value, NRMSE improvement and BIC,
and the slip-jump p-value) is stored and the rule (:func:`stictionbench.diagnosis.
evidence.select`) re-applied offline:

- *package defaults*: ``diagnose``'s own ``alpha`` and ``min_improvement``, chosen by the
  same tuning on the three families pooled (in-sample: see
  :data:`stictionbench.diagnosis.evidence.ALPHA`);
- *tuned on one family*: the thresholds that name most recordings of ``sim_physical``
  correctly subject to ``none`` called physics ≤ 5 % there, reported on all three;
- *leave-one-family-out*: for each family, the thresholds tuned the same way on the other
  two, reported on the one left out (the out-of-sample numbers).

Outputs in ``reports/concealed/``: ``results.csv`` (one row per recording), ``summary.md``
(per family, class and level: named rate with Wilson 95 % interval, ``none`` called
physics, parameter error; leave-one-family-out), ``lofo.csv``, ``detectability.png``
(named rate against effect size and against effect/noise), ``confusion.png``.

Run: ``.venv/bin/python experiments/concealed.py [--seeds N] [--none-seeds M] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import inspect
import itertools
import json
import math
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed_families import (  # noqa: E402
    CLASSES,
    DURATION,
    FAMILIES,
    Case,
    make_recording,
    nominal_model,
)

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.diagnosis.diagnose import after_comparison as diagnosis_after_comparison  # noqa: E402
from stictionbench.diagnosis.evidence import (  # noqa: E402
    FULL_DATA_ALPHA,
    OWN_RESOLUTION,
    VALVE_HYPOTHESES,
    after_second_look,
    failed_gates,
    range_fallback,
    scaled_gate,
    select,
)
from stictionbench.diagnosis.line import LINE_SHARE, named_line  # noqa: E402
from stictionbench.io import atomic_directory, read_recording, write_text  # noqa: E402
from stictionbench.rates import balanced_text, rate_text, wilson  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: the tuning grid reaches past every pick (with the model alpha 0.05 and 0.1; without
#: it 3e-4 and 0.02 or 0): a pick on a grid's end would say only that the search stopped
#: there. Levels above 0.1 are not tests one would ship (the slip-jump interval is the
#: 1 − alpha one); offline re-decisions of the same evidence at alpha 0.2 and 0.3 name
#: 207 and 210 of the 240 recordings with the model against 209 at 0.05, `none` called
#: physics 0 of 72 at each: no level is a clear gain.
ALPHAS = (1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 5e-2, 0.1)
MIN_IMPROVEMENTS = (0.0, 0.02, 0.05, 0.1, 0.15, 0.2)
TUNING_FAMILY = "sim_physical"
#: ``diagnose``'s default thresholds (read from its signature)
DEFAULTS = tuple(inspect.signature(diagnose).parameters[k].default
                 for k in ("alpha", "min_improvement"))
MAX_NONE_RATE = 0.05
T = TypeVar("T")
#: the fitted parameter compared with the truth, per class
MAIN_PARAMETER = {"stiction": "S", "deadband": "deadband", "sensor_lag": "time_constant",
                  "dead_time": "dead_time", "valve_characteristic": "rangeability",
                  "saturation": "op_high", "oscillatory_disturbance": "period"}


def generate(cls: str, level: int, seed: int, out: Path,
             family: str = "sim_physical") -> dict:
    """Write one recording (CSV, no MV) and its nominal-model YAML; return the job."""
    c, sig = make_recording(family, cls, level, seed)
    return write_job(c, sig, out)


def recording_name(c: Case) -> str:
    """The file stem :func:`write_job` gives case ``c``'s recording."""
    return f"{c.family}_L{c.level}_{c.cls}_{c.seed:02d}"


def write_job(c: Case, sig: dict[str, np.ndarray], out: Path) -> dict:
    """Write case ``c``'s recording ``sig`` (t, SP, PV, OP; no MV) as a CSV and its plant
    and PI as the model YAML a user would give; return the job :func:`run_one` takes."""
    name = recording_name(c)
    csv = Path(out) / f"{name}.csv"
    pd.DataFrame({k: sig[k] for k in ("t", "SP", "PV", "OP")}).to_csv(csv, index=False)
    model, m = Path(out) / f"{name}.yaml", nominal_model(c)
    model.write_text(
        f"process: {{gain: {m.gain:.6g}, time_constant: {m.time_constant:.6g}, "
        f"dead_time: {m.dead_time:.6g}}}\n"
        f"controller: {{kc: {m.kc:.6g}, ti: {m.ti:.6g}}}\nsample_time: 1.0\n")
    return {"name": name, "family": c.family, "class": c.cls, "level": c.level,
            "seed": c.seed, "csv": str(csv), "model": str(model), "truth": c.truth,
            "effect": c.effect, "noise_frac": c.noise_frac}


def run_one(job: dict) -> dict:
    """Diagnose one recording blind; keep its evidence for the offline threshold study:
    the main band's ranking and, where it ran, the second look's line
    (:func:`slow_line_evidence`)."""
    t0 = time.perf_counter()
    rec = read_recording(job["csv"], warn=False)
    pem = not job.get("output_error", False)
    d = diagnose(rec, pem=pem) if job.get("model_free") else \
        diagnose(rec, load_model(job["model"]), pem=pem)
    seconds = time.perf_counter() - t0
    return {k: job[k] for k in ("name", "family", "class", "level", "seed", "effect",
                                "noise_frac")} | {
        "predicted_default": d.missing_physics, "truth": json.dumps(job["truth"]),
        **decision_row(d), "seconds": seconds}


def decision_row(d) -> dict:
    """What :func:`decide` re-decides a finished diagnosis from: its ranking
    (:func:`stored_evidence`), the slip-jump p-value, whether the closed-loop cycle was
    reproduced and the dead time judged by its own resolution, the second look's line
    (:func:`slow_line_evidence`), against a given model the band's degrees of freedom
    that scaled the NRMSE gate, and the two checks that name physics where the
    comparison named nothing (OP held at a limit, the set-point gain test:
    :func:`after_comparison`)."""
    return {"evidence": stored_evidence(d),
            "slip_jump_p": d.tests.get("slip_jump_zero", {}).get("p_value"),
            "cycle_reproduced": bool(d.tests.get("closed_loop_cycle", {}).get(
                "reproduced", False)),
            "dead_time_own_resolution": bool(d.details["dead_time_own_resolution"]),
            "slow_line": slow_line_evidence(d),
            "band_dof": d.details["band_dof"] if d.model.source == "given" else None,
            "op_held": bool(d.tests.get("op_held_at_limit", {}).get("held", False)),
            "gain_flagged": bool(d.tests.get("setpoint_gain", {}).get("significant",
                                                                      False)),
            "line_shares": json.dumps(d.tests.get("line_confined", {}).get("shares", {}))}


def stored_evidence(d) -> str:
    """A diagnosis's ranking as the stored evidence the decision rules re-decide
    (:func:`decide`, ``experiments/decision_rules.py``): each hypothesis's tests, effect
    sizes and parameters, and for the valve hypotheses the closed-loop valve
    identification's own in-sample test (``p_identification``)."""
    ham = d.details.get("hammerstein") or {}
    p_ident = ham.get("tests", {}).get("valve_vs_linear", {}).get("p_value")
    return json.dumps([{"physics": r["physics"], "p_value": r["p_value"],
                        "improvement": r["improvement"], "score": r["score"],
                        "improvement_kstep": r["improvement_kstep"], "p_full": r["p_full"],
                        "p_k_step": r["p_k_step"],
                        "p_identification": p_ident if r["physics"] in VALVE_HYPOTHESES
                        else None,
                        "at_bound": r["at_bound"], "parameters": r["parameters"]}
                       for r in d.ranking])


def slow_line_evidence(d) -> str:
    """The second look's line (:func:`stictionbench.diagnosis.diagnose.second_look`) as
    stored evidence, shaped like the diagnosis's ``details["slow_line"]``: its row's gates
    and period, and the main band's corner period; an empty string when the look did not
    run."""
    look = d.details.get("slow_line")
    if look is None:
        return ""
    r = look["oscillatory_disturbance"]
    return json.dumps({"corner_period_s": look["corner_period_s"],
                       "oscillatory_disturbance": {k: r[k] for k in (
                           "physics", "p_value", "improvement", "at_bound", "parameters")}})


def own_resolution_of(row: pd.Series) -> frozenset[str]:
    """The hypotheses a stored diagnosis judged by their own resolution (the rule applied
    only against a given model on a recording with set-point excitation)."""
    return OWN_RESOLUTION if row.get("dead_time_own_resolution", True) else frozenset()


def with_slow_line(row: pd.Series, pick: str, alpha: float, min_improvement: float) -> str:
    """``pick`` (the main band's verdict on one stored row), or the second look's slow
    line where :func:`~stictionbench.diagnosis.evidence.slow_line_named` names it. The
    look was stored only where the package's defaults named nothing in the main band
    (rows stored before the look have none)."""
    look = row.get("slow_line")
    return after_second_look(pick, json.loads(look) if isinstance(look, str) and look
                             else None, alpha=alpha, min_improvement=min_improvement)


def main_band_gate(row: pd.Series, min_improvement: float,
                   gate: Callable[[float, float], float] = scaled_gate) -> float:
    """The main band's NRMSE gate of one stored row: ``min_improvement`` scaled by the
    row's in-band degrees of freedom where they were stored (a given model), by ``gate``
    (the package's :func:`~stictionbench.diagnosis.evidence.scaled_gate` unless varied)."""
    dof = row.get("band_dof")
    if dof is None or not isinstance(dof, int | float) or not math.isfinite(dof):
        return min_improvement
    return gate(min_improvement, float(dof))


def with_range_fallback(row: pd.Series, pick: str,
                        alpha_full: float = FULL_DATA_ALPHA) -> str:
    """``pick`` (after the second look), or the range hypothesis named by the full-data
    test (:func:`~stictionbench.diagnosis.evidence.range_fallback`) where the package
    would apply it: where the second look ran (a given model, prediction-error fits, the
    main band naming nothing; its stored line is non-empty) and named nothing."""
    look = row.get("slow_line")
    if pick != "none" or not (isinstance(look, str) and look):
        return pick
    return range_fallback(pick, json.loads(row["evidence"]), alpha_full=alpha_full)


def after_main_band(row: pd.Series, pick: str, alpha: float, min_improvement: float,
                    alpha_full: float = FULL_DATA_ALPHA) -> str:
    """A main-band verdict followed by what the package does after it: the second look
    (:func:`with_slow_line`), then the range hypotheses' full-data test
    (:func:`with_range_fallback`)."""
    return with_range_fallback(row, with_slow_line(row, pick, alpha, min_improvement),
                               alpha_full)


def after_comparison(row: pd.Series, pick: str) -> str:
    """``pick`` followed by what the diagnosis names after the comparison from the
    stored flags (:func:`stictionbench.diagnosis.diagnose.after_comparison`: OP held at a
    limit, the set-point gain test; thresholds are not varied here). Rows stored before
    the checks lack their flags and keep ``pick``."""
    return diagnosis_after_comparison(pick, _flag(row, "op_held"),
                                      _flag(row, "gain_flagged"))


def _flag(row: pd.Series, key: str) -> bool:
    v = row.get(key, False)
    if isinstance(v, str):
        return v.strip().lower() == "true"
    return bool(v) if v is not None and v == v else False


def decide(row: pd.Series, alpha: float, min_improvement: float,
           alpha_full: float = FULL_DATA_ALPHA,
           gate: Callable[[float, float], float] = scaled_gate,
           line_share: float = LINE_SHARE) -> str:
    """The shipped decision re-applied to one stored row at other thresholds: the main
    band's rule (:func:`~stictionbench.diagnosis.evidence.select`), then the second
    look and the full-data test of the range hypotheses (:func:`after_main_band`), then
    the line test (:func:`after_line`), then the checks after the comparison
    (:func:`after_comparison`; ``line_share`` varies the line test's bound). The
    main band's NRMSE gate is scaled by the stored in-band degrees of freedom
    (:func:`~stictionbench.diagnosis.evidence.scaled_gate`; rows stored before they
    were, and model-free rows, keep ``min_improvement``; ``gate`` varies that law)."""
    pick = select(json.loads(row["evidence"]), row["slip_jump_p"], alpha=alpha,
                  min_improvement=main_band_gate(row, min_improvement, gate),
                  own_resolution=own_resolution_of(row),
                  cycle_reproduced=bool(row.get("cycle_reproduced", False)))
    pick = after_main_band(row, pick, alpha, min_improvement, alpha_full)
    return after_comparison(row, after_line(row, pick, line_share))


def after_line(row: pd.Series, pick: str, threshold: float = LINE_SHARE) -> str:
    """``pick``, or the oscillatory disturbance where ``pick`` is OP-driven and its
    improvement lies at the residual's line (:func:`stictionbench.diagnosis.line.named_line`
    on the stored ``line_shares``; rows stored before the line test keep ``pick``)."""
    shares = row.get("line_shares")
    if not isinstance(shares, str):
        return pick
    return ("oscillatory_disturbance" if named_line(pick, json.loads(shares), threshold)
            else pick)


def picks(df: pd.DataFrame, alpha: float, min_improvement: float) -> pd.Series:
    return df.apply(decide, axis=1, args=(alpha, min_improvement))


def best_setting(df: pd.DataFrame, settings: Iterable[T],
                 picks_of: Callable[[T], pd.Series],
                 tie: Callable[[T], float] = lambda s: 0.0) -> T:
    """The tuning rule: the setting whose verdicts (``picks_of(setting)``) name most
    recordings of ``df`` correctly with ``none`` called physics at most
    :data:`MAX_NONE_RATE` (the lowest ``none`` rate if no setting meets it); ties to the
    first setting of largest ``tie``."""
    best = None
    is_none = df["class"] == "none"
    for s in settings:
        p = picks_of(s)
        none_rate = float((p[is_none] != "none").mean()) if is_none.any() else 0.0
        acc = float((p == df["class"]).mean())
        key = (none_rate <= MAX_NONE_RATE, acc if none_rate <= MAX_NONE_RATE else -none_rate,
               tie(s))
        if best is None or key > best[0]:
            best = (key, s)
    assert best is not None
    return best[1]


def tune(df: pd.DataFrame) -> tuple[float, float]:
    """Thresholds (alpha, min_improvement) by :func:`best_setting`; ties to the smaller
    alpha."""
    return best_setting(df, itertools.product(ALPHAS, MIN_IMPROVEMENTS),
                        lambda s: picks(df, *s), tie=lambda s: -s[0])


def miss_reason(row: pd.Series, pick: str, alpha: float = DEFAULTS[0],
                min_improvement: float = DEFAULTS[1]) -> str:
    """Why a recording of a physics class was not named that class, read from its stored
    evidence: the gates its true hypothesis failed
    (:func:`~stictionbench.diagnosis.evidence.failed_gates`, the rule the diagnosis
    applies) or, when it passed them all, what beat it (the closed-loop cycle check naming
    a valve, the slip-jump test between the two valve hypotheses, or another significant
    hypothesis of lower BIC)."""
    ev = {e["physics"]: e for e in json.loads(row["evidence"])}
    t = ev.get(row["class"])
    if t is None:
        return "not tested"
    own = own_resolution_of(row)
    why = failed_gates(t, alpha, min_improvement, own_resolution=own)
    if why:
        return " + ".join(why)
    if {row["class"], pick} <= set(VALVE_HYPOTHESES):
        return "slip-jump test"
    if pick in VALVE_HYPOTHESES and bool(row.get("cycle_reproduced", False)):
        return f"{pick} named by the cycle check"
    return f"{pick} of lower BIC"


def parameter_error(df: pd.DataFrame, pred: pd.Series) -> pd.Series:
    """Relative error of the class's main fitted parameter where the class was named."""
    out = []
    for (_, r), p in zip(df.iterrows(), pred, strict=True):
        key = MAIN_PARAMETER.get(r["class"])
        if key is None or p != r["class"]:
            out.append(np.nan)
            continue
        ev = {e["physics"]: e for e in json.loads(r["evidence"])}
        truth = json.loads(r["truth"]).get(key)
        fitted = ev.get(r["class"], {}).get("parameters", {}).get(key)
        out.append(abs(fitted / truth - 1) if truth and fitted is not None else np.nan)
    return pd.Series(out, index=df.index)


def table(df: pd.DataFrame, pred: pd.Series) -> pd.DataFrame:
    """Named-correctly rate (Wilson 95 %) and parameter error per family, class, level."""
    err = parameter_error(df, pred)
    rows = []
    for (fam, cls, lvl), g in df.groupby(["family", "class", "level"], sort=False):
        ok = int((pred[g.index] == cls).sum())
        e = err[g.index].dropna()
        rows.append({"family": fam, "class": cls, "level": lvl, "named": rate_text(ok, len(g)),
                     "rate": ok / len(g),
                     "median parameter error": f"{e.median():.0%}" if len(e) else "–"})
    return pd.DataFrame(rows)


def _named(df: pd.DataFrame, pred: pd.Series, sel: pd.Series) -> str:
    return rate_text(int((pred[sel] == df["class"][sel]).sum()), int(sel.sum()))


def _of16(df: pd.DataFrame, pred: pd.Series, sel: pd.Series) -> str:
    """Named right out of 16 with the classes weighted equally (``rates.balanced_score``)."""
    return balanced_text(pred[sel] == df["class"][sel], df["class"][sel], 16)


def none_rates(df: pd.DataFrame, pred: pd.Series) -> list[str]:
    lines = []
    for lvl in (1, 2):
        g = df[(df["class"] == "none") & (df.level == lvl)]
        lines.append(f"level {lvl}: {rate_text(int((pred[g.index] != 'none').sum()), len(g))}")
    return lines


def lofo(df: pd.DataFrame) -> tuple[pd.DataFrame, pd.Series]:
    """Leave-one-family-out: thresholds tuned on two families, decisions on the third."""
    pred = pd.Series("", index=df.index, dtype=object)
    rows = []
    for fam in FAMILIES:
        test = df.family == fam
        alpha, mi = tune(df[~test])
        pred[test] = picks(df[test], alpha, mi)
        for lvl in (1, 2):
            g = df[test & (df.level == lvl)]
            gn = g[g["class"] == "none"]
            rows.append({"held-out family": fam, "level": lvl, "alpha": alpha,
                         "min_improvement": mi,
                         "named correctly": rate_text(int((pred[g.index] == g["class"]).sum()),
                                                 len(g)),
                         "none called physics": rate_text(int((pred[gn.index] != "none").sum()),
                                                     len(gn))})
    return pd.DataFrame(rows), pred


def detectability(df: pd.DataFrame, pred: pd.Series, out: Path) -> Path:
    """Named rate against effect size (left) and against effect / noise (right)."""
    fig, axs = new_figure(2, 4, figsize=(16, 7), sharey=True)
    ok = (pred == df["class"]).astype(float)
    snr = df.effect / df.noise_frac.clip(lower=1e-3)
    for ax, cls in zip(axs.ravel(), [c for c in CLASSES if c != "none"] + ["none"],
                       strict=True):
        bins = np.linspace(0.0, 1.0 if cls != "none" else 0.1, 6)
        for fam in (*FAMILIES, "all families"):
            g = df[(df["class"] == cls) & ((df.family == fam) | (fam == "all families"))]
            x = g.effect if cls != "none" else g.noise_frac
            idx = np.clip(np.digitize(x, bins[1:-1]), 0, len(bins) - 2)
            centres, rates_, lo, hi = [], [], [], []
            for b in range(len(bins) - 1):
                sel = idx == b
                if sel.any():
                    k, n = int(ok[g.index][sel].sum()), int(sel.sum())
                    centres.append(0.5 * (bins[b] + bins[b + 1]))
                    rates_.append(k / n)
                    w = wilson(k, n)
                    lo.append(k / n - w[0])
                    hi.append(w[1] - k / n)
            if fam == "all families":
                ax.errorbar(centres, rates_, yerr=[lo, hi], color="k", marker="s", lw=2,
                            capsize=3, label="all families (Wilson 95 %)")
            else:
                ax.plot(centres, rates_, marker="o", lw=1, alpha=0.6, label=fam)
        ax.set(title=cls, ylim=(-0.05, 1.05))
    for ax in axs[1]:
        ax.set_xlabel("effect size (0–1)")
    axs[1, -1].set_xlabel("noise / set-point step")
    axs[0, 0].set_ylabel("named correctly")
    axs[1, 0].set_ylabel("named correctly")
    axs[0, 0].legend(fontsize=8)
    p1 = save_png(fig, out / "detectability.png")
    fig, ax = new_figure(figsize=(7, 4.5))
    phys = df["class"] != "none"
    bins = np.quantile(snr[phys], np.linspace(0, 1, 7))
    for fam in FAMILIES:
        g = df[phys & (df.family == fam)]
        idx = np.clip(np.digitize(snr[g.index], bins[1:-1]), 0, len(bins) - 2)
        xs = [np.median(snr[g.index][idx == b]) for b in range(len(bins) - 1) if (idx == b).any()]
        ys = [ok[g.index][idx == b].mean() for b in range(len(bins) - 1) if (idx == b).any()]
        ax.plot(xs, ys, marker="o", label=fam)
    ax.set(xscale="log", xlabel="effect size / (noise / set-point step)",
           ylabel="named correctly (all physics classes)", ylim=(-0.05, 1.05))
    ax.legend()
    save_png(fig, out / "detectability_snr.png")
    return p1


def confusion(df: pd.DataFrame, pred: pd.Series, out: Path) -> Path:
    fig, axs = new_figure(1, 2, figsize=(14, 5.5))
    for ax, lvl in zip(axs, (1, 2), strict=True):
        g = df.level == lvl
        m = pd.crosstab(df[g]["class"], pred[g]).reindex(index=list(CLASSES),
                                                         columns=list(CLASSES), fill_value=0)
        ax.imshow(m.to_numpy(), cmap="Blues")
        for i, j in itertools.product(range(m.shape[0]), range(m.shape[1])):
            if m.iat[i, j]:
                ax.text(j, i, m.iat[i, j], ha="center", va="center", fontsize=8)
        ax.set_xticks(range(len(CLASSES)), CLASSES, rotation=60, ha="right")
        ax.set_yticks(range(len(CLASSES)), CLASSES)
        ax.set(xlabel="diagnosed (leave-one-family-out thresholds)", ylabel="true",
               title=f"level {lvl}: {(pred[g] == df[g]['class']).mean():.0%} named correctly")
    return save_png(fig, out / "confusion.png")


def family_rates(df: pd.DataFrame, pred: pd.Series) -> list[str]:
    """One line per family and level: named rate and ``none`` called physics."""
    lines = []
    for fam in FAMILIES:
        for lvl in (1, 2):
            h = (df.family == fam) & (df.level == lvl)
            gn = h & (df["class"] == "none")
            lines.append(f"- {fam}, level {lvl}: named {_named(df, pred, h)}; none called "
                         f"physics {rate_text(int((pred[gn] != 'none').sum()), int(gn.sum()))}")
    return lines


def _pooled(df: pd.DataFrame) -> list[str]:
    """What the tuning rule picks on all three families pooled (in-sample), beside the
    shipped defaults: the defaults' provenance, recomputed on every run."""
    pooled = tune(df)
    is_none = df["class"] == "none"

    def score(pair: tuple[float, float]) -> str:
        p = picks(df, *pair)
        return (f"named {int((p == df['class']).sum())}/{len(df)}, `none` called physics "
                f"{int((p[is_none] != 'none').sum())}/{int(is_none.sum())}")

    return [f"Pooled tuning on all three families (in-sample) picks alpha = {pooled[0]:g}, "
            f"min_improvement = {pooled[1]:g}: {score(pooled)}; the shipped defaults: "
            f"{score(DEFAULTS)}."]


def summary(df: pd.DataFrame, tuned: tuple[float, float], lofo_tab: pd.DataFrame,
            lofo_pred: pd.Series, wall: float, args: argparse.Namespace) -> str:
    p_tuned = picks(df, *tuned)
    # the seeds the recordings were drawn with (read from them: --report-only rewrites
    # the summary of a run made with other counts)
    size = df.groupby(["family", "class", "level"]).size()
    none = size.xs("none", level="class") if "none" in df["class"].values else size.iloc[:0]
    seeds = int(size.drop("none", level="class", errors="ignore").max())
    none_seeds = int(none.max()) if len(none) else 0
    per = table(df, lofo_pred)
    wide = per.pivot_table(index=["class", "level"], columns="family", values="named",
                           aggfunc="first").reindex(columns=list(FAMILIES)).reset_index()
    lines = [
        "# Concealed-data benchmark: three generator families, leave-one-family-out"
        + (" — model-free (no nominal model given)" if args.model_free else "")
        + (" — output-error fits (for comparison)" if args.output_error else ""), "",
        "Fit criterion: " + ("output error (every hypothesis fitted on its simulation "
                             "error; `--output-error`), judged by the same prediction-error "
                             "tests" if args.output_error else
                             "one-step prediction errors under the noise model of the "
                             "nominal output error (the package default; the output-error "
                             "fits of the earlier method are in `--output-error` runs)")
        + ".", "",
        f"{len(df)} recordings ({DURATION:.0f} s at 1 s, t/SP/PV/OP only, MV never written): "
        f"{seeds} seeds per family × class × level, {none_seeds} for `none`. "
        "Generated and diagnosed by `experiments/concealed.py` (`make concealed`); families "
        "in `experiments/concealed_families.py`. Rates carry Wilson 95 % intervals.", "",
        "## Leave-one-family-out (out of sample)", "",
        to_markdown(lofo_tab), "",
        f"- overall, level 1: {_named(df, lofo_pred, df.level == 1)}; "
        f"level 2: {_named(df, lofo_pred, df.level == 2)}",
        "- of 16 drawn as the concealed set is (2 of each class, `none` one of the 8; "
        f"these counts hold {none_seeds / seeds:.3g}× as many `none` as of any other "
        "class): "
        + "; ".join(f"level {lvl} {_of16(df, lofo_pred, df.level == lvl)}" for lvl in (1, 2)),
        f"- `none` called physics: {'; '.join(none_rates(df, lofo_pred))}", "",
        "## The package defaults (what `stictionbench diagnose` answers)", "",
        f"alpha = {DEFAULTS[0]:g}, min_improvement = {DEFAULTS[1]:g}: "
        + ("chosen on the with-model benchmark (`reports/concealed/`), so out of sample "
           "here. Without a model a dead-time or sensor-lag mismatch is absorbed by the "
           "identified FOPDT: those classes are not identifiable and are expected to "
           "read `none`." if args.model_free else
           "chosen on the prediction-error benchmark (`reports/concealed/`); these "
           "output-error fits are shown for comparison." if args.output_error else
           "set from the same tuning on all three families pooled (recomputed below; where "
           "the two differ, `stictionbench.diagnosis.evidence.ALPHA` says why), so "
           "**in-sample** here; the leave-one-family-out numbers above are the "
           "out-of-sample estimate of that choice."), "",
        *family_rates(df, df.predicted_default), "",
        *_pooled(df), "",
        f"## Thresholds tuned on `{TUNING_FAMILY}` only: alpha = {tuned[0]:g}, "
        f"min_improvement = {tuned[1]:g}", "",
        "In-sample on that family, out of sample on the other two.", "",
    ]
    lines += family_rates(df, p_tuned)
    lines += ["", "## Per class, level and family (leave-one-family-out thresholds)", "",
              to_markdown(wide), ""]
    if not (args.model_free or args.output_error):
        lines += ["The sticky valves missed here, checked against one cause by varying it "
                  "(the same recordings with the controller's period changed to the "
                  "historian's), and whether their slip jump is in the 1 s signals at all "
                  "(Kano's sampled model fitted to the true valve position): "
                  "[stiction_controller_rate.md](stiction_controller_rate.md).", ""]
    lines += ["Median relative error of the class's main parameter "
              "where it was named (LOFO):", "",
              to_markdown(per.pivot_table(index=["class", "level"], columns="family",
                                          values="median parameter error", aggfunc="first")
                          .reindex(columns=list(FAMILIES)).reset_index()), "",
              "![detectability](detectability.png)", "",
              "![detectability vs signal to noise](detectability_snr.png)", "",
              "![confusion](confusion.png)", "",
              timing_line(df, wall, args.jobs)]
    return "\n".join(lines) + "\n"


def timing_line(df: pd.DataFrame, wall: float | None, jobs: int) -> str:
    """The report's line on diagnosis time (per recording, and the run's wall time;
    ``wall`` None: the report was rewritten from ``results.csv``)."""
    run = (f"total wall {wall:.0f} s with {jobs} workers" if wall is not None else
           "the run's wall time is not in results.csv (report rewritten by --report-only)")
    return (f"Diagnosis time per recording: median {df.seconds.median():.2f} s, max "
            f"{df.seconds.max():.2f} s; {run}.")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--none-seeds", type=int, default=12)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--model-free", action="store_true",
                    help="diagnose without the nominal-model YAML (the plant case: a FOPDT "
                         "is identified from the recording); default out: "
                         "reports/concealed_model_free")
    ap.add_argument("--output-error", action="store_true",
                    help="fit the hypotheses by output error instead of prediction error "
                         "(the earlier method); default out: reports/concealed_output_error")
    ap.add_argument("--out", default=None)
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite summary.md from the folder's results.csv (the thresholds "
                         "and leave-one-family-out picks recomputed), diagnosing nothing")
    a = ap.parse_args(argv)
    a.out = a.out or str(ROOT / "reports" / ("concealed" + ("_model_free" if a.model_free
                                                            else "")
                                             + ("_output_error" if a.output_error else "")))
    if a.seeds < 1 or a.none_seeds < 1 or a.jobs == 0:
        ap.error("--seeds and --none-seeds must be at least 1, --jobs not 0")
    if a.report_only:
        if not (Path(a.out) / "results.csv").is_file():
            ap.error(f"--report-only: no results.csv in {a.out}; run without it first")
        df = pd.read_csv(Path(a.out) / "results.csv", keep_default_na=False,
                         na_values={c: [""] for c in ("slip_jump_p", "band_dof", "effect")})
        tuned = tune(df[df.family == TUNING_FAMILY])
        lofo_tab, lofo_pred = lofo(df)
        text = summary(df, tuned, lofo_tab, lofo_pred, None, a)
        write_text(Path(a.out) / "summary.md", text)
        print(text)
        return 0
    from joblib import Parallel, delayed
    from tqdm import tqdm

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [generate(c, lvl, s, Path(tmp), fam) | {"model_free": a.model_free,
                                                           "output_error": a.output_error}
                for fam in FAMILIES for lvl in (1, 2)
                for c in CLASSES for s in range(a.none_seeds if c == "none" else a.seeds)]
        # the bar moves when a recording is diagnosed, not when it is dispatched
        rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
            delayed(run_one)(j) for j in jobs), total=len(jobs), desc="diagnose"))
    df = pd.DataFrame(rows)
    tuned = tune(df[df.family == TUNING_FAMILY])
    lofo_tab, lofo_pred = lofo(df)
    df["predicted_lofo"] = lofo_pred
    df["predicted_tuned"] = picks(df, *tuned)
    with atomic_directory(a.out) as out:
        out = Path(out)
        df.round({"effect": 6, "noise_frac": 6, "seconds": 3}).to_csv(
            out / "results.csv", index=False, lineterminator="\n", float_format="%.6g")
        lofo_tab.to_csv(out / "lofo.csv", index=False, lineterminator="\n")
        detectability(df, lofo_pred, out)
        confusion(df, lofo_pred, out)
        text = summary(df, tuned, lofo_tab, lofo_pred, time.perf_counter() - t0, a)
        (out / "summary.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
