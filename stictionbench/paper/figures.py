"""Figures 1–21 of the paper, and the figures of the sensitivity studies.

Every figure is drawn from measured data of this run (or of the committed sweeps); file
names ``figNN.png`` follow the paper's numbering.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..reports.figures import new_figure, save_png
from .cases import CASES, METHOD_TITLES, CaseResult

#: the paper's captions, verbatim (Fig. 10's is the paper's own copy of Fig. 7's)
PAPER_CAPTIONS = {
    1: "Servo response with PI controller",
    2: "Response for stem position and controller output",
    3: "Plot for Manipulated variable Vs Controller output",
    4: "Servo response with tightly tuned controller",
    5: "Response for stem position and controller output",
    6: "Plot for Manipulated variable Vs Controller output",
    7: "Servo response with oscillatory disturbance",
    8: "Response for stem position and controller output",
    9: "Plot for Controller output Vs Process variable.",
    10: "Servo response with oscillatory disturbance",
    11: "Response for stem position and controller output",
    12: "Plot for Controller output Vs Manipulated variable.",
    13: "Plot for Controller output Vs Process variable.",
    14: "Response for process with PI controller (valve is linear)",
    15: "Response for process with tightly tuned controller",
    16: "Response for process with oscillatory disturbance",
    17: "Response for process with presence of stiction",
    18: "Response for process with PI controller",
    19: "Response for process with tightly tuned controller",
    20: "Response for process with oscillatory disturbance",
    21: "Response for process with presence of stiction",
}
#: (case, kind) of Figures 1–13
TIME_FIGURES = [("linear", "servo"), ("linear", "stem"), ("linear", "mv"),
                ("tight", "servo"), ("tight", "stem"), ("tight", "mv"),
                ("disturbance", "servo"), ("disturbance", "stem"), ("disturbance", "pv"),
                ("stiction", "servo"), ("stiction", "stem"), ("stiction", "mv"),
                ("stiction", "pv")]
CASE_COLOURS = {"linear": "C0", "tight": "C1", "disturbance": "C2", "stiction": "C3"}
EST_COLOURS = {"xcorr": "C0", "xcum": "C1", "horch": "C2", "ellipse": "C3",
               "bicoherence_dec": "C4"}


def _time_plot(r: CaseResult, t_end: float, series: list[tuple[str, str, str]],
               ylabel: str, title: str):
    """Signals of one case against time up to ``t_end``: ``(signal, style, label)``."""
    fig, ax = new_figure()
    m = r.rec.t <= t_end
    for name, style, label in series:
        ax.plot(r.rec.t[m], r.rec.signal(name)[m], style, label=label)
    ax.set(xlabel="time (s)", ylabel=ylabel, title=title)
    ax.legend(loc="lower right")
    return fig


def _servo(r: CaseResult, w: float, title: str):
    return _time_plot(r, w, [("SP", "k--", "SP"), ("PV", "-", "PV")],
                      "PV, SP (% of span)", title)


def _stem(r: CaseResult, w: float, title: str):
    return _time_plot(r, 2 * w, [("OP", "-", "controller output CO (OP)"),
                                 ("MV", "-", "stem position MV")], "% of span", title)


def _phase(r: CaseResult, y: str, title: str):
    ellipse = y == "PV" and bool(r.ellipse.diagnostics.get("fitted"))
    fig, axs = new_figure(1, 2 if ellipse else 1, figsize=(10.5, 4.0) if ellipse else None,
                          squeeze=False, constrained_layout=True)
    ax = axs[0, 0]
    ax.plot(r.rec.OP, r.rec.signal(y), lw=0.6, color="0.4", label=f"{y} vs CO (raw)")
    ax.set(xlabel="controller output CO (%)",
           ylabel="manipulated variable MV (%)" if y == "MV" else "process variable PV (%)",
           title=title)
    ax.legend(loc="upper left", framealpha=0.6)
    if ellipse:
        # the ellipse is fitted to band-passed data: drawn on those, beside the raw plot
        d = r.ellipse.diagnostics
        ax2 = axs[0, 1]
        ax2.plot(d["op_filtered"], d["pv_filtered"], lw=0.5, color="C0",
                 label="band-passed PV vs CO")
        e = d["ellipse"]
        ax2.plot(e[:, 0], e[:, 1], "r", lw=1.5,
                 label=f"ellipse fit: apparent stiction {float(r.ellipse.value):.1f} %")
        ax2.set(xlabel="CO, band-passed (%)", ylabel="PV, band-passed (%)",
                title="what the ellipse is fitted to")
        ax2.legend(loc="upper left", framealpha=0.6)
    return fig


def paper_figures(results: list[CaseResult], cfg: Any, fig_dir: Path) -> dict[int, Path]:
    """Figures 1–21 in the paper's order; returns number -> path."""
    by = {r.case: r for r in results}
    w = float(cfg.servo_window)
    paths: dict[int, Path] = {}
    for n, (case, kind) in enumerate(TIME_FIGURES, start=1):
        if case not in by:
            continue
        r = by[case]
        title = f"Fig. {n} ({case}) {PAPER_CAPTIONS[n].rstrip('.')}"
        fig = (_servo(r, w, title) if kind == "servo" else _stem(r, w, title)
               if kind == "stem" else _phase(r, "MV" if kind == "mv" else "PV", title))
        paths[n] = save_png(fig, fig_dir / f"fig{n:02d}.png")
    n = 14
    for method in ("xcorr", "xcum"):
        for case in CASES:
            if case in by:
                paths[n] = save_png(_delay_curve(by[case], method, n), fig_dir / f"fig{n:02d}.png")
            n += 1
    return paths


def _delay_curve(r: CaseResult, method: str, n: int):
    res = r.xcorr if method == "xcorr" else r.xcum
    d = res.diagnostics
    fig, ax = new_figure()
    if method == "xcorr":
        ax.plot(d["lags"], d["curve"], lw=1)
        lo, hi = d.get("backward_path_window") or (None, None)
        if lo is not None:
            ax.axvspan(lo, hi, color="0.85", label="MV→PV→CO path window [−(θ+τ), −θ]")
        ax.set(ylabel="ML-windowed cross-correlation r(m)")
        label = f"estimate {float(res.value):.4g} samples"
    else:
        ax.stem(d["lags"], d["curve"], basefmt=" ")
        flags = [f for f, on in (("on the window's edge", d["at_edge"]),
                                 ("moves with the window", d["unstable"])) if on]
        label = f"arg-max {int(res.value)} samples" + (f" ({', '.join(flags)})" if flags
                                                         else "")
        ax.set(ylabel="cumulant model coefficient a(k)")
    ax.axvline(float(res.value), color="r", ls="--", label=label)
    ax.set(xlabel=f"lag (samples of {r.rec.Ts:g} s); positive: MV lags CO",
           title=f"Fig. {n} {METHOD_TITLES[method]}: {r.case} — "
                 f"{PAPER_CAPTIONS[n]}")
    ax.legend(loc="upper left", framealpha=0.7)
    return fig


def _band(ax, x, med, lo, hi, **kw):
    ax.plot(x, med, marker="o", **kw)
    ax.fill_between(x, lo, hi, alpha=0.15, color=kw.get("color"))


def window_figure(win: pd.DataFrame, path: Path) -> Path:
    """Estimate (median and IQR) against max_delay and segment length, four cases."""
    fig, axs = new_figure(1, 3, figsize=(13, 4))
    g = win[win.load == win.load.max()]
    for ax, (method, knob) in zip(axs, (("xcorr", "max_delay"), ("xcum", "max_delay"),
                                        ("xcorr", "segsamp")), strict=True):
        for case in CASES:
            s = g[(g.case == case) & (g.method == method) & (g.knob == knob)]
            _band(ax, s.setting, s["median"], s.q25, s.q75, color=CASE_COLOURS[case],
                  label=case)
        ax.set_xscale("log")
        ax.set_xticks(sorted(set(g[g.knob == knob].setting)))
        ax.set_xticklabels([str(v) for v in sorted(set(g[g.knob == knob].setting))])
        ax.minorticks_off()
        ax.axhline(0, color="k", lw=0.5)
        ax.set(xlabel=f"{knob} (samples)", ylabel="CO→MV delay (samples), median, IQR",
               title=f"{method} vs {knob}")
    axs[0].legend()
    return save_png(fig, path)


def rate_figure(panels: list[tuple[str, pd.DataFrame, str, str]], path: Path,
                ncols: int = 3) -> Path:
    """Rates with Wilson intervals: one panel per ``(title, table, x column, xlabel)``;
    one line per ``estimator`` (and per ``case`` when the table has one)."""
    nrows = int(np.ceil(len(panels) / ncols))
    fig, axs = new_figure(nrows, ncols, figsize=(4.6 * ncols, 3.9 * nrows), squeeze=False,
                          constrained_layout=True)
    for ax, (title, tab, xcol, xlabel) in zip(axs.flat, panels, strict=False):
        groups = [c for c in ("case", "valve") if c in tab] + ["estimator"]
        for i, (key, s) in enumerate(tab.groupby(groups, sort=False)):
            key = key if isinstance(key, tuple) else (key,)
            s = s.sort_values(xcol)
            x = np.arange(len(s)) if xcol == "sample_time" else s[xcol].to_numpy(float)
            if "valve" in tab:  # colour by estimator, line style by valve
                colour = EST_COLOURS.get(key[-1], "k")
                ls = "--" if key[0] == "linear" else "-"
            else:
                colour = CASE_COLOURS.get(key[0], EST_COLOURS.get(key[0], f"C{i % 10}"))
                ls = "-" if key[-1] in ("xcorr", "ellipse") else "--"
            jitter = 0.006 * i * (np.ptp(np.log(x)) if xcol in ("S", "period_over_tc")
                                  else (np.ptp(x) or 1))
            x = x * np.exp(jitter) if xcol in ("S", "period_over_tc") else x + jitter
            ax.errorbar(x, s.rate,
                        yerr=[s.rate - s.lo, s.hi - s.rate], marker="o", ms=3,
                        capsize=2, lw=1, ls=ls, color=colour, label=" ".join(map(str, key)))
        if xcol == "sample_time":
            ticks = sorted(set(tab[xcol]))
            ax.set_xticks(range(len(ticks)), [f"{v:g}" for v in ticks])
        elif (tab[xcol] > 0).all() and tab[xcol].max() / tab[xcol].min() > 8:
            ax.set_xscale("log")
            ticks = sorted(set(tab[xcol]))
            ax.set_xticks(ticks, [f"{v:g}" for v in ticks])
            ax.minorticks_off()
        ax.set(title=title, xlabel=xlabel, ylabel="'stiction' rate, 95 % CI", ylim=(-0.03, 1.03))
        ax.legend(fontsize=6)
    for ax in list(axs.flat)[len(panels):]:
        ax.set_visible(False)
    return save_png(fig, path)


def roc_figure(cases: pd.DataFrame, path: Path) -> Path:
    """ROC curves of the signed and unsigned delays, stiction vs each other case."""
    from ..rates import roc_curve

    fig, axs = new_figure(1, 4, figsize=(15, 3.8))
    g = cases[cases.load == cases.load.max()]
    st = g[g.case == "stiction"]
    for ax, (p, kind) in zip(axs, [(p, k) for p in ("xcorr", "xcum")
                                   for k in ("signed", "unsigned")], strict=True):
        for other in ("linear", "tight", "disturbance"):
            ot = g[g.case == other]
            v = np.r_[st[f"{p}_value"].to_numpy(float), ot[f"{p}_value"].to_numpy(float)]
            lab = np.r_[np.ones(len(st), bool), np.zeros(len(ot), bool)]
            fpr, tpr, auc = roc_curve(v if kind == "signed" else np.abs(v), lab)
            ax.plot(fpr, tpr, color=CASE_COLOURS[other], label=f"vs {other}: AUC {auc:.2f}")
        ax.plot([0, 1], [0, 1], "k:", lw=0.5)
        ax.set(title=f"{p}, {kind} delay", xlabel="false-alarm rate", ylabel="detection rate")
        ax.legend(loc="lower right")
    return save_png(fig, path)
