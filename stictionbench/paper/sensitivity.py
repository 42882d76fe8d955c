"""The replication's unstated choices, swept: rates with intervals and ROC areas.

Reads the results of the Hydra sweeps ``conf/sweep/paper_*.yaml`` (``make sweep-paper``
writes ``reports/sweeps/paper_*/results.csv``) and reduces them to tables of rates, each
with its Wilson 95 % interval, and ROC areas with percentile-bootstrap intervals
(:mod:`stictionbench.rates`). Nothing here simulates.

Rules compared (the paper states only the first):

- **sign** — the paper's literal rule: a positive CO→MV delay means stiction, zero or
  negative means none (section V: "negative and zero values indicate ... not ...
  nonlinearity", "+0.0046847 ... stiction");
- **threshold** — ours: delay > 0.5 samples (``estimators.*.threshold``);
- **edge-aware** — the estimator's own ``decision``: for ``xcum`` no call is made when the
  lag sits on the window's edge or moves with the window / a truncated-SVD solve.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

from ..rates import auc_interval, decided, rate_text, wilson

SWEEPS = ("paper_cases", "paper_sampling", "paper_noise", "paper_magnitude",
          "paper_period", "paper_margin")
#: crossover period of C·G = 0.06 e^(−10 s)/s and ultimate gain of the paper's loop
CROSSOVER_PERIOD = 2 * np.pi / 0.06
ULTIMATE_GAIN = np.pi / (2 * 10.0 * 0.3)
WINDOW_VARIANTS = {"xcorr": ("xcorr_m10", "xcorr_m20", "xcorr", "xcorr_m50", "xcorr_m80"),
                   "xcum": ("xcum_m10", "xcum_m20", "xcum", "xcum_m50", "xcum_m80")}
WINDOWS = (10, 20, 30, 50, 80)
SEGMENTS = {"xcorr_s64": 64, "xcorr": 128, "xcorr_s256": 256, "xcorr_s512": 512}


def load_sweeps(root: str | Path = "reports/sweeps") -> dict[str, pd.DataFrame]:
    """``results.csv`` of every paper sweep found under ``root`` (missing ones absent)."""
    out = {}
    for name in SWEEPS:
        path = Path(root) / name / "results.csv"
        if path.exists():
            df = pd.read_csv(path)
            out[name] = df[df["status"] == "ok"].reset_index(drop=True).copy()
    return out


def rule_hits(df: pd.DataFrame, prefix: str, rule: str) -> np.ndarray:
    """Boolean "stiction" calls of one estimator column under a rule."""
    v = pd.to_numeric(df[f"{prefix}_value"], errors="coerce").to_numpy(float)
    if rule == "sign":
        return np.nan_to_num(v, nan=0.0) > 0
    if rule == "threshold":
        return np.nan_to_num(v, nan=0.0) > 0.5
    if rule == "edge-aware":
        return decided(df[f"{prefix}_decision"])
    raise ValueError(rule)


def rate_cells(hits: np.ndarray) -> dict[str, float | int | str]:
    """``k``, ``n``, ``rate``, Wilson ``lo``/``hi`` and the text cell of a boolean array."""
    k, n = int(np.sum(hits)), int(np.size(hits))
    lo, hi = wilson(k, n)
    return {"k": k, "n": n, "rate": k / n if n else np.nan, "lo": lo, "hi": hi,
            "text": rate_text(k, n)}


def rates(df: pd.DataFrame, by: list[str], prefixes: Iterable[str],
          rule: str = "threshold") -> pd.DataFrame:
    """Long table: one row per group × estimator with its stiction-call rate."""
    rows = []
    for keys, g in df.groupby(by, sort=True):
        keys = keys if isinstance(keys, tuple) else (keys,)
        for p in prefixes:
            rows.append({**dict(zip(by, keys, strict=True)), "estimator": p, "rule": rule,
                         **rate_cells(rule_hits(g, p, rule))})
    return pd.DataFrame(rows)


def rules_table(cases: pd.DataFrame) -> pd.DataFrame:
    """Detection and false-alarm rates of the paper's estimators under the three rules,
    per trajectory kind (load 0: the paper's trajectory; 0.5: random trajectories)."""
    out = []
    for rule in ("sign", "threshold", "edge-aware"):
        r = rates(cases, ["load", "case"], ("xcorr", "xcum"), rule)
        out.append(r)
    long = pd.concat(out, ignore_index=True)
    wide = long.pivot_table(index=["load", "estimator", "rule"], columns="case",
                            values="text", aggfunc="first").reset_index()
    return wide[["load", "estimator", "rule", "stiction", "linear", "tight", "disturbance"]]


def window_table(cases: pd.DataFrame) -> pd.DataFrame:
    """Estimate against window (max_delay) and segment length, per case: median, IQR,
    threshold-rule rate with interval, and the share of flagged (edge/unstable) lags."""
    rows = []
    specs = [(m, p, "max_delay", w) for m, ps in WINDOW_VARIANTS.items()
             for p, w in zip(ps, WINDOWS, strict=True)]
    specs += [("xcorr", p, "segsamp", s) for p, s in SEGMENTS.items()]
    for (load, case), g in cases.groupby(["load", "case"], sort=True):
        for method, p, knob, w in specs:
            v = pd.to_numeric(g[f"{p}_value"], errors="coerce").to_numpy(float)
            edge = decided(g[f"{p}_at_edge"])
            flagged = edge | decided(g[f"{p}_unstable"]) if f"{p}_unstable" in g else edge
            rows.append({"load": load, "case": case, "method": method, "knob": knob,
                         "setting": w, "median": float(np.median(v)),
                         "q25": float(np.quantile(v, 0.25)),
                         "q75": float(np.quantile(v, 0.75)),
                         "positive": rate_cells(v > 0.5)["text"],
                         "rate": float(np.mean(v > 0.5)),
                         "flagged": float(np.mean(flagged))})
    return pd.DataFrame(rows)


def roc_table(cases: pd.DataFrame, prefixes: Iterable[str] = ("xcorr", "xcum")
              ) -> pd.DataFrame:
    """ROC area of each estimator's signed and unsigned delay, stiction against each
    non-stiction case, with 95 % bootstrap intervals (1000 resamples, seed 0)."""
    rows = []
    for load, g in cases.groupby("load", sort=True):
        st = g[g.case == "stiction"]
        for other in ("linear", "tight", "disturbance"):
            ot = g[g.case == other]
            lab = np.r_[np.ones(len(st), bool), np.zeros(len(ot), bool)]
            for p in prefixes:
                v = np.r_[st[f"{p}_value"].to_numpy(float), ot[f"{p}_value"].to_numpy(float)]
                for kind, score in (("signed", v), ("unsigned", np.abs(v))):
                    a, lo, hi = auc_interval(score, lab)
                    rows.append({"load": load, "estimator": p, "statistic": kind,
                                 "against": other, "auc": a, "lo": lo, "hi": hi,
                                 "text": f"{a:.2f} [{lo:.2f}, {hi:.2f}]"})
    return pd.DataFrame(rows)


def baseline_table(cases: pd.DataFrame) -> pd.DataFrame:
    """Stiction calls of the baselines (Horch's OP–PV cross-correlation test, the ellipse
    on OP–PV, bicoherence on PV raw and decimated) per case, with intervals."""
    r = rates(cases, ["load", "case"], [p for p in ("horch", "ellipse", "bicoherence",
                                                    "bicoherence_dec")
                                        if f"{p}_decision" in cases], "edge-aware")
    return r.pivot_table(index=["load", "estimator"], columns="case", values="text",
                         aggfunc="first").reset_index()[
        ["load", "estimator", "stiction", "linear", "tight", "disturbance"]]


def one_factor(df: pd.DataFrame, knob: str, others: Iterable[str], prefixes: Iterable[str],
               by: Iterable[str] = ()) -> pd.DataFrame:
    """Rates against one knob with the ``others`` at zero (a one-factor slice of a grid)."""
    keep = np.ones(len(df), bool)
    for o in others:
        keep &= df[o].to_numpy(float) == 0
    return rates(df[keep], [*by, knob], prefixes)


def noise_table(noise: pd.DataFrame) -> pd.DataFrame:
    """Threshold-rule rates per case against noise on PV, CO (OP) and MV, one at a time."""
    knobs = ("noise", "noise_op", "noise_mv")
    parts = []
    for k in knobs:
        r = one_factor(noise, k, [o for o in knobs if o != k], ("xcorr", "xcum"), ["case"])
        r = r.rename(columns={k: "level"})
        r.insert(0, "signal", {"noise": "PV", "noise_op": "CO", "noise_mv": "MV"}[k])
        parts.append(r)
    return pd.concat(parts, ignore_index=True)


def sampling_table(samp: pd.DataFrame) -> pd.DataFrame:
    """Per case and sampling interval (windows fixed in seconds): median delay in
    samples and seconds, and threshold-rule rates."""
    r = rates(samp, ["case", "sample_time"], ("xcorr", "xcum"))
    med = samp.groupby(["case", "sample_time"]).agg(
        xcorr_median=("xcorr_value", "median"), xcum_median=("xcum_value", "median"))
    return r.merge(med.reset_index(), on=["case", "sample_time"])


def magnitude_table(mag: pd.DataFrame) -> pd.DataFrame:
    """Rates against stiction size S (% of span) for every estimator of the sweep."""
    r = rates(mag, ["load", "S"], _present(mag, ("xcorr", "xcum", "horch", "ellipse",
                                                  "bicoherence_dec")))
    edge = mag.groupby(["load", "S"])["xcum_at_edge"].apply(
        lambda s: float(np.mean(decided(s)))).rename("xcum_edge_rate").reset_index()
    return r.merge(edge, on=["load", "S"])


def period_table(per: pd.DataFrame) -> pd.DataFrame:
    """Rates against the disturbance period relative to the crossover period."""
    per = per.assign(period_over_tc=(per["dist_period"] / CROSSOVER_PERIOD).round(2))
    return rates(per, ["valve", "period_over_tc"],
                 _present(per, ("xcorr", "xcum", "horch", "ellipse", "bicoherence_dec")))


def margin_table(mar: pd.DataFrame) -> pd.DataFrame:
    """Rates against the controller gain relative to the ultimate gain."""
    mar = mar.assign(kc_over_ku=(mar["kc"] / ULTIMATE_GAIN).round(2))
    return rates(mar, ["valve", "kc_over_ku"],
                 _present(mar, ("xcorr", "xcum", "horch", "ellipse", "bicoherence_dec")))


def _present(df: pd.DataFrame, prefixes: Iterable[str]) -> list[str]:
    """The estimator columns a sweep's results hold."""
    return [p for p in prefixes if f"{p}_value" in df]
