"""Figures: matplotlib on the Agg backend, saved as PNG without timestamps or version
strings in their metadata, so that two runs give byte-identical files."""

from __future__ import annotations

import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ..io import atomic_path  # noqa: E402

STYLE = {
    "figure.figsize": (6.4, 4.0),
    "figure.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "font.size": 9,
    "legend.fontsize": 8,
    "svg.hashsalt": "stictionbench",
}


def new_figure(nrows: int = 1, ncols: int = 1, **kw):
    """A figure in the house style: ``fig, ax = new_figure()``."""
    with plt.rc_context(STYLE):
        return plt.subplots(nrows, ncols, **kw)


def save_png(fig, path: str | Path, dpi: int = 100) -> Path:
    """Save ``fig`` to ``path`` atomically with deterministic metadata, then close it."""
    with atomic_path(path) as tmp, plt.rc_context(STYLE), warnings.catch_warnings():
        # a loop named in a script the font lacks (e.g. CJK) is drawn with boxes; the
        # figure stays useful, and stderr stays one line per real problem
        warnings.filterwarnings("ignore", message="Glyph .* missing from font")
        fig.savefig(tmp, format="png", dpi=dpi, metadata={"Software": None},
                    bbox_inches="tight")
    plt.close(fig)
    return Path(path)
