"""Figures of a sweep: detection-rate heatmaps and ROC curves per estimator."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..rates import decided, roc_curve
from ..reports.figures import new_figure, save_png


def _levels(df: pd.DataFrame, col: str) -> list:
    if col not in df:
        return [None]
    return sorted(df[col].dropna().unique().tolist())


def detection_heatmaps(df: pd.DataFrame, prefixes: list[str], path: Path) -> Path:
    """Share of runs with decision True per (stiction S × noise), one panel per tuning.

    Rows: estimator variants; columns: controller gain ``kc``; cells pool every other
    knob (valve model, J ratio, disturbance, seed). The S = 0 row is the false-alarm
    rate, the others the detection rate.
    """
    ok = df[df["status"] == "ok"]
    S, noise, kc = _levels(ok, "S"), _levels(ok, "noise"), _levels(ok, "kc")
    nrows, ncols = max(1, len(prefixes)), len(kc)
    fig, axes = new_figure(nrows, ncols, figsize=(max(5.5, 1.2 + 2.3 * ncols), 0.6 + 1.9 * nrows),
                           squeeze=False, constrained_layout=True)
    image = None
    for i, p in enumerate(prefixes):
        dec = decided(ok[f"{p}_decision"])
        for j, k in enumerate(kc):
            ax = axes[i][j]
            grid = np.full((len(S), len(noise)), np.nan)
            count = np.zeros_like(grid, dtype=int)
            for a, s in enumerate(S):
                for b, n in enumerate(noise):
                    m = np.ones(len(ok), bool)
                    if s is not None:
                        m &= (ok["S"] == s).to_numpy()
                    if n is not None:
                        m &= (ok["noise"] == n).to_numpy()
                    if k is not None:
                        m &= (ok["kc"] == k).to_numpy()
                    if m.any():
                        grid[a, b] = dec[m].mean()
                        count[a, b] = int(m.sum())
            image = ax.imshow(100 * grid, origin="lower", aspect="auto", vmin=0.0,
                              vmax=100.0, cmap="viridis")
            for a in range(len(S)):
                for b in range(len(noise)):
                    if np.isfinite(grid[a, b]):
                        ax.text(b, a, f"{100 * grid[a, b]:.0f}", ha="center", va="center",
                                fontsize=7, color="w" if grid[a, b] < 0.6 else "k")
            ax.set_xticks(range(len(noise)), [f"{n:g}" if n is not None else "" for n in noise])
            ax.set_yticks(range(len(S)), [f"{s:g}" if s is not None else "" for s in S])
            ax.grid(False)
            if i == 0:
                ax.set_title(f"Kc = {k:g}" if k is not None else "")
            if i == nrows - 1:
                ax.set_xlabel("noise (PV units rms)")
            if j == 0:
                ax.set_ylabel(f"{p}\nS (% of span)")
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.6, label="runs with decision True (%)")
    fig.suptitle(f"Runs with decision True (%), {len(ok)} runs\nrow S = 0: the false-alarm "
                 "rate", fontsize="medium")
    return save_png(fig, path)


def roc_figure(df: pd.DataFrame, prefixes: list[str], path: Path) -> Path:
    """ROC of every estimator variant's ``value`` against ``label_stiction``.

    The marker on each curve is the estimator's own decision (its operating point).
    """
    ok = df[df["status"] == "ok"]
    label = ok["label_stiction"].map(lambda v: v is True or v == 1).to_numpy(dtype=bool)
    fig, ax = new_figure(figsize=(8.4, 5.0))
    ax.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls=":")
    for i, p in enumerate(prefixes):
        vals = pd.to_numeric(ok[f"{p}_value"], errors="coerce").to_numpy(dtype=float)
        fpr, tpr, auc = roc_curve(vals, label)
        # ten colours, then the next line style: no two curves drawn alike
        (line,) = ax.plot(fpr, tpr, lw=1.3, color=f"C{i % 10}",
                          ls=("-", "--", "-.", ":")[i // 10 % 4], label=f"{p} (AUC {auc:.2f})")
        dec = decided(ok[f"{p}_decision"])
        if label.any() and (~label).any():
            ax.plot(dec[~label].mean(), dec[label].mean(), "o", color=line.get_color(), ms=5)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.01)
    ax.set_aspect("equal")
    ax.set_xlabel("false alarm rate (stiction-free runs)")
    ax.set_ylabel("detection rate (runs with stiction)")
    ax.set_title(f"ROC of each estimator's value, {len(ok)} runs "
                 f"({int(label.sum())} with stiction); o = its decision")
    ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize="small")
    return save_png(fig, path)
