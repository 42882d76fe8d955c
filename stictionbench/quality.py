"""Data-quality screening of a Recording before any diagnosis.

:func:`screen` answers "can this record be diagnosed at all, and what should the reader
know about it?" It returns a :class:`QualityReport` with ``usable``, one short line per
reason when it is not, warnings that do not forbid a diagnosis, and the numbers behind
every decision in ``flags``.

Rules (thresholds are keyword parameters of :func:`screen`, defaults in brackets):

- *dead* PV or OP: ``max|x| < dead_abs`` (1e-30; a failed tag reads e.g. 3.5e-44) —
  unusable;
- *constant*: ``ptp(x) <= const_rtol·max(1, max|x|)`` (1e-9) — unusable;
- *stuck*: unchanged over more than ``max_stuck_frac`` (95 %) of steps — unusable;
- *historian compression*: ``compression_frac`` = share of steps held (PV and OP both
  unchanged) or linearly interpolated (both on a straight line) — unusable above
  ``max_compression_frac`` (0.5), warning above ``warn_compression_frac`` (0.1);
- *quantisation*: fewer than ``min_quant_steps`` (10) quanta across a signal's range —
  unusable; fewer than ``warn_quant_steps`` (100) — warning;
- *interpolated missing values* (``meta["warnings"]`` of :meth:`Recording.from_arrays`):
  more than ``max_interpolated_frac`` (10 %) of samples — unusable; any — warning;
- *OP saturation*: OP within ``sat_rtol`` (0.5 %) of its range from its minimum or
  maximum for more than ``max_sat_frac`` (20 %) of samples — unusable;
- *mean-removed / normalised*: ``|mean| <= mean_rtol·std`` (1e-3) for PV and OP, or
  ``std ≈ 1`` for both — flag and warning, not unusable;
- *few periods*: the record spans fewer than ``min_periods`` (3) periods of the PV's
  regular oscillation (ACF, Thornhill et al. 2003) — flag and warning;
- *short*: fewer than ``warn_samples`` (500) samples — warning (records under 100
  samples are already refused by :meth:`Recording.from_arrays`).

Choices and why:

- Compression is measured as in ``plant/labels.csv``: ``held_frac`` is the share of
  sample-to-sample steps in which PV *and* OP are both unchanged (box-car, i.e.
  hold-last-value, reconstruction by the historian); ``linear_frac`` adds steps where
  both lie on a straight line (linear-interpolation reconstruction, whose signature,
  a zero second difference, Thornhill, Choudhury & Shah 2004 use to detect compression).
  A compressed record with fill share ``h`` holds about ``1/(1 − h)`` raw samples per
  stored one. Above ``h = 0.5`` most of the record is historian fill, not measurement:
  it is declared unusable. This is deliberately strict for stiction work: a box-car
  hold is a flat stretch of PV and OP, indistinguishable from the *stick* phase of a
  sticky valve, and compression is known to induce apparent nonlinearity (the
  bicoherence test's evidence for stiction). Between 0.1 and 0.5 the record is
  usable with a warning. A signal whose quantum is at least half its median
  sample-to-sample move is left out of the held share (it holds because it cannot
  resolve smaller moves), and one whose quantum exceeds 1 % of that move is left out
  of the linear share (equal successive steps then happen by chance); when every
  signal is left out, the held share is reported but not judged.
- Quantisation is detected from the gaps between the distinct values (all integer
  multiples of one quantum ``q``); ``range/q`` is the number of quantisation steps the
  signal spans. A fine grid (CSV values printed to a few decimals) is reported but not
  flagged; fewer than 100 steps draws a warning, fewer than 10 makes the signal
  unusable (its shape — the PV–OP ellipse, a stick-slip jump — is not resolved).
- Saturation: an OP pinned at a limit means the loop is open for that time and a
  saturation limit cycle resembles stiction; more than 20 % of the record at the
  observed minimum or maximum makes it unusable. The test uses the observed extremes,
  so it also works on scaled data.
- Mean-removed or normalised data (ISDB CHEM10–13) are not unusable: oscillation and
  shape analyses still work, but absolute levels (a valve at 0 % or 100 %, the
  operating point) cannot be reasoned about; ``flags["normalised"]`` says so.

References
----------
N. F. Thornhill, M. A. A. S. Choudhury, S. L. Shah, "The impact of compression on
data-driven process analyses", J. Process Control 14 (2004) 389–398.
M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, *Diagnosis of Process Nonlinearities
and Valve Stiction*, Springer 2008, chapter 4 (compression and quantisation detection).
N. F. Thornhill, B. Huang, H. Zhang, "Detection of multiple oscillations in control
loops", J. Process Control 13 (2003) 91–100.
M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops*,
Springer 2010 (ISDB; mean-removed loops).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import InputError
from .recording import Recording

_INTERP = re.compile(r"interpolated (\d+) missing values")


@dataclass(frozen=True)
class QualityReport:
    """Outcome of :func:`screen`.

    Attributes
    ----------
    usable : bool
        False when any rule forbids a diagnosis.
    reasons : list of str
        Why it is unusable, one short line each (empty when usable).
    flags : dict
        Numbers and booleans behind the decisions (JSON-ready): ``n``, ``Ts``,
        ``held_frac``, ``linear_frac``, ``compression_frac``, per signal
        ``PV_quantum``, ``PV_steps``, ``PV_held_frac`` ..., ``OP_sat_frac``,
        ``mean_removed``, ``unit_variance``, ``normalised``, ``interpolated_frac``,
        ``pv_period_samples``, ``n_periods``, and one boolean per rule.
    warnings : list of str
        Issues that do not forbid a diagnosis but qualify it.
    name : str
        The recording's name (``meta["name"]``, else its source).
    """

    usable: bool
    reasons: list[str]
    flags: dict[str, Any]
    warnings: list[str] = field(default_factory=list)
    name: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"name": self.name, "usable": self.usable, "reasons": list(self.reasons),
                "warnings": list(self.warnings), "flags": dict(self.flags)}

    def summary(self) -> str:
        """One line: the reasons when unusable, else the warnings (or ``ok``)."""
        if not self.usable:
            return "; ".join(self.reasons)
        return "; ".join(self.warnings) if self.warnings else "ok"


# --------------------------------------------------------------------------- measures
def held_fraction(*signals: np.ndarray) -> float:
    """Share of sample-to-sample steps in which every signal is exactly unchanged.

    With PV and OP this is ``held_frac`` of ``plant/labels.csv``: the historian's
    hold-last-value (box-car) fill.

    Examples
    --------
    >>> held_fraction(np.array([1., 1, 2, 2, 3]), np.array([5., 5, 6, 7, 8]))
    0.25
    """
    same = np.ones(signals[0].size - 1, dtype=bool)
    for x in signals:
        same &= np.diff(x) == 0
    return float(same.mean()) if same.size else 0.0


def linear_fraction(*signals: np.ndarray, rtol: float = 1e-6) -> float:
    """Share of steps in which every signal moves and lies on a straight line.

    A step ``k`` counts when ``Δx[k] ≠ 0`` and ``|Δ²x| <= rtol·max(|Δx[k−1]|, |Δx[k]|)``
    for every signal — the zero second difference left by linear-interpolation
    reconstruction (Thornhill, Choudhury & Shah 2004).

    Examples
    --------
    >>> x = np.r_[np.linspace(0, 1, 50), np.linspace(1, 0, 50)]
    >>> round(linear_fraction(x), 2)
    0.97
    """
    n = signals[0].size
    if n < 3:
        return 0.0
    on = np.ones(n - 2, dtype=bool)
    for x in signals:
        d = np.diff(x)
        d2 = np.diff(d)
        scale = np.maximum(np.abs(d[:-1]), np.abs(d[1:]))
        on &= (d[1:] != 0) & (np.abs(d2) <= rtol * scale)
    return float(on.sum() / (n - 1))


def estimate_quantum(
    x: np.ndarray, *, grid_tol: float = 0.1, min_on_grid: float = 0.9
) -> float | None:
    """Quantisation step of a signal, or None when its values are not on a grid.

    The distinct values are sorted and their gaps ``g`` taken (gaps below
    ``1e-9·range`` are float noise and merged). A candidate quantum ``q`` is the median
    of the gaps up to 1.5 × their 10th percentile; the signal is quantised when at least
    ``min_on_grid`` of all gaps are within ``grid_tol·q`` of a positive integer multiple
    of ``q``. For a continuous signal the gaps are spread out (about a fifth land near
    a multiple by chance).

    Parameters
    ----------
    x : ndarray
    grid_tol : float
        Tolerance, as a fraction of ``q``, for a gap to count as a multiple of ``q``.
    min_on_grid : float
        Share of gaps that must be multiples of ``q``.

    Returns
    -------
    float or None

    References
    ----------
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, *Diagnosis of Process
    Nonlinearities and Valve Stiction*, Springer 2008, section 4 (quantisation).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> s = np.cumsum(rng.normal(size=2000))
    >>> round(estimate_quantum(np.round(s / 0.5) * 0.5), 6)
    0.5
    >>> estimate_quantum(s) is None
    True
    """
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    u = np.unique(x)
    if u.size < 3:
        return None
    span = float(u[-1] - u[0])
    g = np.diff(u)
    g = g[g > 1e-9 * span]
    if g.size < 2:
        return None
    g10 = float(np.percentile(g, 10))
    q = float(np.median(g[g <= 1.5 * g10]))
    r = g / q
    k = np.round(r)
    on = (k >= 1) & (np.abs(r - k) <= grid_tol)
    if on.mean() < min_on_grid:
        return None
    # refine on the gaps of exactly one quantum
    one = g[(k == 1) & on]
    return float(np.median(one)) if one.size else q


def _saturation(op: np.ndarray, rtol: float) -> tuple[float, float]:
    """Shares of samples within ``rtol·range`` of the minimum and of the maximum."""
    lo, hi = float(op.min()), float(op.max())
    tol = rtol * (hi - lo)
    return float(np.mean(op <= lo + tol)), float(np.mean(op >= hi - tol))


def _pct(f: float) -> str:
    return f"{100 * f:.0f} %" if f >= 0.01 else f"{100 * f:.1f} %"


# --------------------------------------------------------------------------- screen
def screen(
    rec: Recording,
    *,
    dead_abs: float = 1e-30,
    const_rtol: float = 1e-9,
    max_stuck_frac: float = 0.95,
    warn_compression_frac: float = 0.1,
    max_compression_frac: float = 0.5,
    linear_rtol: float = 1e-6,
    warn_quant_steps: float = 100.0,
    min_quant_steps: float = 10.0,
    max_sat_frac: float = 0.2,
    sat_rtol: float = 0.005,
    mean_rtol: float = 1e-3,
    unit_std_tol: float = 0.02,
    max_interpolated_frac: float = 0.1,
    min_periods: float = 3.0,
    warn_samples: int = 500,
) -> QualityReport:
    """Screen a Recording's data quality before any diagnosis.

    Parameters
    ----------
    rec : Recording
        The record. With ``meta["op_only"]`` (OP-only benchmark loops, PV = OP) the PV
        rules are skipped.
    dead_abs : float
        A signal with ``max|x| < dead_abs`` is dead (a failed tag, e.g. PV ≈ 3.5e-44).
    const_rtol : float
        A signal with ``ptp(x) <= const_rtol·max(1, max|x|)`` is constant.
    max_stuck_frac : float
        A signal unchanged over more than this share of steps is stuck (unusable).
    warn_compression_frac, max_compression_frac : float
        Historian-fill share (``held_frac + linear_frac``) above which a warning is
        given (0.1) and the record is unusable (0.5); see the module notes.
    linear_rtol : float
        Relative tolerance on the second difference for :func:`linear_fraction`.
    warn_quant_steps, min_quant_steps : float
        Quantisation steps across a signal's range below which a warning is given
        (100) and the signal is unusable (10).
    max_sat_frac, sat_rtol : float
        OP within ``sat_rtol·range`` of its minimum or maximum for more than
        ``max_sat_frac`` of the samples is saturated (unusable).
    mean_rtol : float
        ``|mean| <= mean_rtol·std`` for both PV and OP: mean-removed data (flag).
    unit_std_tol : float
        ``|std − 1| <= unit_std_tol`` for both: unit-variance (normalised) data (flag).
    max_interpolated_frac : float
        Share of interpolated samples (from ``meta["warnings"]``) above which the record
        is unusable; any interpolation gives a warning.
    min_periods : float
        Fewer periods of the PV's regular oscillation in the record: flag ``few_periods``.
    warn_samples : int
        Fewer samples: warning (spectral and bicoherence tests need several hundred).

    Returns
    -------
    QualityReport

    References
    ----------
    N. F. Thornhill, M. A. A. S. Choudhury, S. L. Shah, "The impact of compression on
    data-driven process analyses", J. Process Control 14 (2004) 389–398.
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, *Diagnosis of Process
    Nonlinearities and Valve Stiction*, Springer 2008, chapter 4.
    N. F. Thornhill, B. Huang, H. Zhang, J. Process Control 13 (2003) 91–100.

    Examples
    --------
    >>> t = np.arange(1000.0)
    >>> rec = Recording.from_arrays(t, np.full(1000, 3.5e-44), np.sin(t / 20))
    >>> rep = screen(rec)
    >>> rep.usable, rep.reasons
    (False, ['PV dead (|PV| < 1e-30 throughout: failed tag?)'])
    """
    op_only = bool(rec.meta.get("op_only", False))
    names = ("OP",) if op_only else ("PV", "OP")
    sig = {s: np.asarray(getattr(rec, s), dtype=float) for s in names}
    n = len(rec)
    reasons: list[str] = []
    warnings: list[str] = []
    flags: dict[str, Any] = {"n": n, "Ts": float(rec.Ts), "duration_s": float(n * rec.Ts),
                             "op_only": op_only}

    # -- dead, constant, stuck -------------------------------------------------------
    bad: set[str] = set()
    for s, x in sig.items():
        amax = float(np.max(np.abs(x)))
        ptp = float(np.ptp(x))
        stuck = float(np.mean(np.diff(x) == 0))
        flags[f"{s}_ptp"] = ptp
        flags[f"{s}_held_frac"] = stuck
        flags[f"{s}_dead"] = amax < dead_abs
        flags[f"{s}_constant"] = ptp <= const_rtol * max(1.0, amax)
        flags[f"{s}_stuck"] = stuck > max_stuck_frac
        if flags[f"{s}_dead"]:
            reasons.append(f"{s} dead (|{s}| < {dead_abs:g} throughout: failed tag?)")
            bad.add(s)
        elif flags[f"{s}_constant"]:
            reasons.append(f"{s} constant (range {ptp:.3g})")
            bad.add(s)
        elif flags[f"{s}_stuck"]:
            reasons.append(f"{s} stuck: unchanged in {_pct(stuck)} of steps")
            bad.add(s)

    # -- quantisation ----------------------------------------------------------------
    motion_q: dict[str, bool] = {}
    coarse_steps: dict[str, bool] = {}
    for s, x in sig.items():
        q = None if s in bad else estimate_quantum(x)
        steps = float(np.ptp(x) / q) if q else math.inf
        moves = np.abs(np.diff(x))
        moves = moves[moves > 0]
        move = float(np.median(moves)) if moves.size else 0.0
        # quantisation limits the sample-to-sample motion: holds are then expected
        motion_q[s] = bool(q) and move > 0 and q >= 0.5 * move
        # steps resolved to fewer than ~100 levels: equal successive steps (a "straight
        # line") then happen by chance
        coarse_steps[s] = bool(q) and move > 0 and q >= 0.01 * move
        flags[f"{s}_quantum"] = q
        flags[f"{s}_steps"] = steps if q else None
        flags[f"{s}_levels"] = int(np.unique(x).size)
        flags[f"{s}_quantised"] = bool(q) and steps < warn_quant_steps
        flags[f"{s}_motion_quantised"] = motion_q[s]
        if q and steps < min_quant_steps:
            reasons.append(f"{s} quantised too coarsely: {steps:.0f} steps of {q:.3g} "
                           f"across its range")
            bad.add(s)
        elif q and steps < warn_quant_steps:
            warnings.append(f"{s} quantised: {steps:.0f} steps of {q:.3g} across its range")

    # -- historian compression -------------------------------------------------------
    # Holds of a signal whose motion is limited by its quantum are expected without any
    # compression, so such signals are left out; when all are, compression cannot be
    # told from quantisation and is only reported. Straight runs are not sought in
    # signals whose steps are quantised (equal successive steps happen by chance).
    cont = [s for s in sig if not motion_q[s]]
    ambiguous = not cont
    use = list(sig) if ambiguous else cont
    held = held_fraction(*(sig[s] for s in use))
    lin_use = [s for s in use if not coarse_steps[s]]
    lin = linear_fraction(*(sig[s] for s in lin_use), rtol=linear_rtol) if lin_use else 0.0
    comp = held + lin
    flags.update(held_frac=held, linear_frac=lin, compression_frac=comp,
                 compression_factor=(1.0 / (1.0 - comp)) if comp < 1 else math.inf,
                 compression_signals="+".join(use), compression_ambiguous=ambiguous,
                 compressed=(not ambiguous) and comp > warn_compression_frac)
    what = " and ".join(use)
    detail = f"held {_pct(held)}" + (f", linear {_pct(lin)}" if lin >= 0.005 else "")
    if ambiguous:
        if comp > warn_compression_frac:
            warnings.append(f"{what} unchanged in {_pct(comp)} of steps ({detail}): "
                            f"expected from quantisation, not counted as compression")
    elif comp > max_compression_frac:
        reasons.append(f"heavy historian compression: {what} unchanged or interpolated "
                       f"in {_pct(comp)} of steps ({detail}; limit "
                       f"{_pct(max_compression_frac)})")
    elif comp > warn_compression_frac:
        warnings.append(f"historian compression: {what} unchanged or interpolated in "
                        f"{_pct(comp)} of steps ({detail})")

    # -- interpolated missing values -------------------------------------------------
    notes = [str(w) for w in rec.meta.get("warnings", ())]
    n_interp = sum(int(m.group(1)) for w in notes for m in _INTERP.finditer(w))
    frac_interp = n_interp / n
    flags.update(interpolated_values=n_interp, interpolated_frac=frac_interp)
    if frac_interp > max_interpolated_frac:
        reasons.append(f"{n_interp} interpolated missing values ({_pct(frac_interp)} of "
                       f"samples; limit {_pct(max_interpolated_frac)})")
    elif n_interp:
        warnings.append(f"{n_interp} missing values interpolated")

    # -- OP saturation ---------------------------------------------------------------
    op = sig["OP"]
    if "OP" not in bad:
        lo_f, hi_f = _saturation(op, sat_rtol)
        flags.update(OP_sat_low_frac=lo_f, OP_sat_high_frac=hi_f,
                     OP_sat_frac=max(lo_f, hi_f), OP_min=float(op.min()),
                     OP_max=float(op.max()))
        flags["saturated"] = max(lo_f, hi_f) > max_sat_frac
        if flags["saturated"]:
            side, f, v = (("minimum", lo_f, op.min()) if lo_f >= hi_f
                          else ("maximum", hi_f, op.max()))
            reasons.append(f"OP saturated at its {side} ({v:.4g}) for {_pct(f)} of samples")
    else:
        flags["saturated"] = None

    # -- mean-removed / normalised ---------------------------------------------------
    means = {s: float(np.mean(x)) for s, x in sig.items()}
    stds = {s: float(np.std(x)) for s, x in sig.items()}
    for s in sig:
        flags[f"{s}_mean"] = means[s]
        flags[f"{s}_std"] = stds[s]
    live = [s for s in sig if s not in bad]
    mean_removed = bool(live) and all(abs(means[s]) <= mean_rtol * stds[s] for s in live)
    unit_var = bool(live) and all(abs(stds[s] - 1.0) <= unit_std_tol for s in live)
    flags.update(mean_removed=mean_removed, unit_variance=unit_var,
                 normalised=mean_removed or unit_var)
    if flags["normalised"]:
        kind = ("mean-removed, unit variance" if mean_removed and unit_var
                else "mean-removed" if mean_removed else "unit variance")
        warnings.append(f"data normalised ({kind}): absolute levels such as valve "
                        f"saturation cannot be judged")

    # -- record length vs oscillation period -----------------------------------------
    flags["pv_period_samples"] = None
    flags["n_periods"] = None
    flags["few_periods"] = False
    target = "OP" if op_only else "PV"
    if target not in bad:
        from .estimators.oscillation import acf_oscillation

        try:
            res = acf_oscillation(sig[target], rec.Ts, max_lag=n - 1)
        except InputError:
            res = None
        if res is not None and res.oscillating:
            periods = n / res.period_samples
            flags["pv_period_samples"] = float(res.period_samples)
            flags["n_periods"] = float(periods)
            flags["few_periods"] = periods < min_periods
            if periods < min_periods:
                warnings.append(f"only {periods:.1f} periods of the {target} oscillation "
                                f"(period {res.period:.4g} s) in the record; at least "
                                f"{min_periods:g} are needed")
    if n < warn_samples:
        warnings.append(f"short record: {n} samples")
    flags["short"] = n < warn_samples

    name = str(rec.meta.get("name") or rec.meta.get("source", ""))
    return QualityReport(usable=not reasons, reasons=reasons, flags=_clean(flags),
                         warnings=warnings, name=name)


def _clean(flags: dict[str, Any]) -> dict[str, Any]:
    """Plain Python scalars; non-finite floats become None (JSON has no inf/NaN)."""
    out: dict[str, Any] = {}
    for k, v in flags.items():
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, float) and not math.isfinite(v):
            v = None
        out[k] = v
    return out
