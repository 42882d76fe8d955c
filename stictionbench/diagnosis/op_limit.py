"""OP held at a limit: a saturated actuator read from the recording itself.

A controller output that sits at the end of its range — the valve fully open or shut,
or the controller's own output clamp — leaves the loop open for as long as it stays
there: the controller asks for more and nothing more happens. When the recorded OP is
the clamped one, the plant sees exactly the recorded OP, so a comparison of PV with the
nominal model driven by that OP finds *no* mismatch: the limit is not missing from the
model's response to OP, it is missing from the controller's reach. What shows it is OP
itself: exactly constant at its extreme for consecutive samples, while a PI acting on a
noisy PV moves its output every sample (Jelali, *Control Performance Management in
Industrial Automation*, Springer 2013, sect. 13.2, saturation as the share of time the
controller output spends at its limits; Thornhill & Horch, Control Eng. Practice 15
(2007) 1196–1206, on saturated actuators as a plant-wide nuisance).

The rule has no tuned threshold: OP held at its recorded maximum (or minimum) for at
least :data:`MIN_RUN` consecutive samples, where OP is not held elsewhere (a compressed
or coarsely quantised OP holds anywhere: there the extreme only counts when it is the
end of OP's known range).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..stretches import true_runs

#: consecutive samples exactly at the extreme that make a hold (two equal samples happen
#: to a coarsely printed OP; three exactly equal ones at the very extreme, with OP moving
#: everywhere else, do not)
MIN_RUN = 3
#: exactly unchanged steps away from the extremes above which OP counts as held anywhere
#: (compressed or coarsely quantised: ``quality.own_holds``)
HELD_ELSEWHERE = 0.01
#: an extreme within this share of the range of an end of OP's known range is that end
RANGE_END_RTOL = 0.005
#: whether OP exactly on an end of its known range on at least :data:`MIN_RUN` samples,
#: not consecutive, is a hold too (a PI executing faster than the historian is clamped
#: between samples and kicked off the limit by PV noise, so its snapshots sit on the
#: limit in ones and twos; an output that moves is exactly on 0 or 100 % only when
#: clamped)
SCATTERED = False


def _runs(mask: np.ndarray, min_run: int) -> tuple[int, int, int]:
    """Samples in runs of ``mask`` at least ``min_run`` long, the number of such runs and
    the longest run (:func:`stictionbench.stretches.true_runs`)."""
    lengths = np.array([b - a for a, b in true_runs(mask)], dtype=int)
    long_ = lengths[lengths >= min_run]
    return int(long_.sum()), int(long_.size), int(lengths.max(initial=0))


def _key(row: dict[str, Any], scattered: bool) -> tuple[float, int]:
    """Which extreme to report: the one with more of OP in holds, then (counting
    scattered samples) the one OP sits on more often."""
    return row["fraction"], row["samples_at_end"] if scattered else 0


def held_at_limit(op: np.ndarray, op_range: tuple[float, float] | None = None, *,
                  min_run: int = MIN_RUN, scattered: bool = SCATTERED) -> dict[str, Any]:
    """Whether OP is held at an end of its range, and where and how long.

    Parameters
    ----------
    op : ndarray
        The recorded controller output.
    op_range : (float, float), optional
        OP's 0 and 100 % in its own units, when known.
    min_run : int
        Consecutive samples exactly at the extreme that make a hold.
    scattered : bool
        Also count as held an extreme that is an end of ``op_range`` where OP sits
        exactly on at least ``min_run`` samples, consecutive or not
        (:data:`SCATTERED`).

    Returns
    -------
    dict
        ``held`` (bool), ``side`` (``"high"``, ``"low"`` or ``None``), ``limit`` (OP's
        value there), ``fraction`` (share of samples in holds of at least ``min_run``),
        ``runs``, ``longest_run`` (samples), ``held_elsewhere`` (share of exactly
        unchanged steps away from the extremes), ``at_range_end`` (the extreme is an
        end of ``op_range``), ``samples_at_end`` (samples exactly on it, there) and
        ``by`` (``"run"``, ``"scattered"`` or ``None``: which rule found the hold).

    Examples
    --------
    >>> op = np.r_[np.linspace(40.0, 99.0, 50), [100.0] * 6, np.linspace(99.0, 60.0, 50)]
    >>> r = held_at_limit(op, (0.0, 100.0))
    >>> r["held"], r["side"], r["limit"], r["runs"], r["longest_run"]
    (True, 'high', 100.0, 1, 6)
    >>> held_at_limit(np.sin(np.arange(200) / 7.0))["held"]
    False
    """
    from ..realdata.quality import own_holds

    x = np.asarray(op, dtype=float)
    lo, hi = float(np.min(x)), float(np.max(x))
    span = hi - lo
    out: dict[str, Any] = {"held": False, "side": None, "limit": None, "fraction": 0.0,
                           "runs": 0, "longest_run": 0, "min_run": min_run,
                           "held_elsewhere": 0.0, "at_range_end": False,
                           "samples_at_end": 0, "by": None}
    if not span > 0:
        return out
    elsewhere = own_holds(x)
    out["held_elsewhere"] = elsewhere
    tol = 1e-9 * max(span, abs(hi), abs(lo))
    best = None
    for side, v in (("high", hi), ("low", lo)):
        at = np.abs(x - v) <= tol
        n_in, n_runs, longest = _runs(at, min_run)
        end = op_range is not None and abs(
            v - (op_range[1] if side == "high" else op_range[0])) <= RANGE_END_RTOL * (
            op_range[1] - op_range[0])
        row = {"side": side, "limit": v, "fraction": n_in / x.size, "runs": n_runs,
               "longest_run": longest, "at_range_end": bool(end),
               "samples_at_end": int(at.sum()) if end else 0}
        if best is None or _key(row, scattered) > _key(best, scattered):
            best = row
    out.update(best)
    by_run = best["runs"] > 0 and (elsewhere < HELD_ELSEWHERE or best["at_range_end"])
    by_count = scattered and best["samples_at_end"] >= min_run
    out["held"] = bool(by_run or by_count)
    out["by"] = "run" if by_run else ("scattered" if by_count else None)
    return out
