"""The training and validation blocks of a diagnosis: how the record after the burn-in is
cut, and which blocks fit and which judge.

The shipped layout is *interleaved*: ``n_blocks`` equal blocks after the burn-in, the even
ones training, the odd ones validation, so every validation block lies between two training
blocks and a slowly varying fit is judged on the record's middle as well as its ends
(cross-validation by contiguous blocks: Ljung, *System Identification* (1999), ch. 16;
Arlot & Celisse, *Statistics Surveys* 4 (2010) 40, on cross-validation of dependent data).
Two one-sided layouts exist to check what the interleaving does: *train_first* fits the
first ``⌈n_blocks/2⌉`` blocks and judges the rest (a forecast past the fitted span),
*validation_first* judges the first ``⌊n_blocks/2⌋`` and fits the rest. In them the knots
of a line's drifting amplitude (:func:`.hypotheses.line_knots`) stop at the training span,
and the amplitude is held constant over the validation span, a prediction, never fitted
there. ``experiments/block_layout.py`` measures the three against each other.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: the layouts :func:`split_blocks` knows; the first is the default
LAYOUTS = ("interleaved", "train_first", "validation_first")
#: blocks after the burn-in (the default)
N_BLOCKS = 5


class Blocks(NamedTuple):
    """Rows of one split: the block edges (rows), training and validation rows, and the
    edges (rows) that carry a line's knots."""

    edges: np.ndarray
    train: np.ndarray
    val: np.ndarray
    knot_edges: np.ndarray


def split_blocks(n: int, burn: int, n_blocks: int = N_BLOCKS,
                 layout: str = "interleaved") -> Blocks:
    """Cut rows ``burn … n−1`` into ``n_blocks`` equal blocks and assign them.

    Parameters
    ----------
    n, burn : int
        Rows in the record; rows before ``burn`` are neither fitted nor judged.
    n_blocks : int
        Number of blocks (at least 2).
    layout : str
        One of :data:`LAYOUTS` (see the module docstring).

    Returns
    -------
    Blocks

    Examples
    --------
    >>> b = split_blocks(110, 10, 5)
    >>> b.edges.tolist(), b.train[[0, -1]].tolist(), b.val[[0, -1]].tolist()
    ([10, 30, 50, 70, 90, 110], [10, 109], [30, 89])
    >>> b = split_blocks(110, 10, 5, "train_first")
    >>> b.train[[0, -1]].tolist(), b.val[[0, -1]].tolist(), b.knot_edges.tolist()
    ([10, 69], [70, 109], [10, 30, 50, 70])
    """
    if layout not in LAYOUTS:
        raise ValueError(f"block_layout must be one of {LAYOUTS}, got {layout!r}")
    if int(n_blocks) != n_blocks or n_blocks < 2:
        raise ValueError(f"n_blocks must be an integer of at least 2, got {n_blocks!r}")
    n_blocks = int(n_blocks)
    edges = np.linspace(burn, n, n_blocks + 1).round().astype(int)
    blocks = [np.arange(edges[i], edges[i + 1]) for i in range(n_blocks)]
    if layout == "interleaved":
        return Blocks(edges, np.concatenate(blocks[0::2]), np.concatenate(blocks[1::2]),
                      edges)
    k = (n_blocks + 1) // 2 if layout == "train_first" else n_blocks // 2
    first, last = np.concatenate(blocks[:k]), np.concatenate(blocks[k:])
    if layout == "train_first":
        return Blocks(edges, first, last, edges[:k + 1])
    return Blocks(edges, last, first, edges[k:])
