"""Data-quality screening of a Recording before any diagnosis.

:func:`screen` answers "can this record be diagnosed at all, and what should the reader
know about it?" It returns a :class:`QualityReport` with ``usable``, one short line per
reason when it is not, warnings that do not forbid a diagnosis, and the numbers behind
every decision in ``flags``.

Every aspect scores 1 (no problem) down to 0 between its warning level and its limit;
``flags["score"]`` is the product and ``flags["grade"]`` reads it (good ≥ 0.8, fair
≥ 0.5, poor). ``unusable`` is kept for data that cannot support a verdict. Thresholds
are keyword parameters of :func:`screen` (defaults in brackets):

- *dead* PV or OP: ``max|x| < dead_abs`` (1e-30; a failed tag reads e.g. 3.5e-44) —
  unusable; *constant* (``ptp(x) <= 1e-9·max(1, max|x|)``) and *stuck* (unchanged over
  more than 95 % of steps) — unusable;
- *historian compression*: ``compression_frac`` = share of steps held (PV and OP both
  unchanged) or linearly interpolated — warning and falling score above 0.1, unusable
  above 0.9 (almost nothing measured). :func:`release_holds` treats held samples as
  missing and bridges the short gaps before the detectors run;
- *quantisation*: fewer than 100 quanta across a signal's range — warning, score falling
  log-linearly to 0 at 5; fewer than 5 — unusable (no shape is resolved);
- *interpolated missing values* (``meta["warnings"]``): score falling to 0 at 50 % of
  samples, unusable above; any — warning;
- *OP saturation* (within 0.5 % of its range from its minimum or maximum): warning and
  falling score above 20 % of samples, unusable above 80 % (the loop open throughout);
- *mean-removed / normalised*: flag and warning, not unusable;
- *OP and PV independent* (Haugh's test at 5 %, the diagnosis's pairing test): warning
  only — a tag of another loop, or a PV that does not measure;
- *few periods* of the PV's regular oscillation (ACF, Thornhill et al. 2003): warning,
  score ``periods / 3``; *short* records (< 500 samples): warning, score ``n / 500``.

Choices and why:

- Compression is measured as in ``plant/labels.csv``: ``held_frac`` is the share of
  sample-to-sample steps in which PV *and* OP are both unchanged (box-car, i.e.
  hold-last-value, reconstruction by the historian); ``linear_frac`` adds steps where
  both lie on a straight line (linear-interpolation reconstruction, whose signature,
  a zero second difference, Thornhill, Choudhury & Shah 2004 use to detect compression).
  A compressed record with fill share ``h`` holds about ``1/(1 − h)`` raw samples per
  stored one. A box-car hold is a flat stretch of PV *and* OP (during a stick phase OP
  keeps moving), and compression is known to induce apparent nonlinearity (the
  bicoherence test's evidence for stiction): the score falls as ``h`` grows and the
  batch bridges short holds as missing data; only above ``h = 0.9`` is the record
  declared unusable (the first release's hard limit of 0.5 turned away a stiction loop
  with 51 % fill). A signal whose quantum is at least half its median
  sample-to-sample move is left out of the held share (it holds because it cannot
  resolve smaller moves), and one whose quantum exceeds 1 % of that move is left out
  of the linear share (equal successive steps then happen by chance); when every
  signal is left out, the held share is reported but not judged. A tag compressed on
  its own (``PV_compressed_frac`` / ``OP_compressed_frac``: holds away from the
  signal's extremes, so a saturated OP does not count) draws a warning but is not
  bridged: a held PV reads like a valve that does not move, but bridging it turns a
  stick followed by a slip into a ramp (``experiments/compression.py``: on the labelled
  real windows bridging each tag removed the false alarms and a third of the
  detections).
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

from ..errors import InputError
from ..estimators.noise_floor import FILLED
from ..recording import HOLD_SHARE, Recording
from ..sim.measurement import held_fraction
from ..validation import jsonable

#: share of held steps above which a signal (or the record) is taken as compressed
HOLD_WARN = 0.1

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
@dataclass
class _Findings:
    """What the aspects of :func:`screen` find: reasons (unusable), warnings, flags and
    one score in [0, 1] per aspect."""

    flags: dict[str, Any]
    reasons: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    scores: dict[str, float] = field(default_factory=dict)
    bad: set[str] = field(default_factory=set)


def _ramp(x: float, full: float, zero: float) -> float:
    """1 at ``x <= full``, 0 at ``x >= zero``, linear between (or the mirror image when
    ``zero < full``)."""
    if zero > full:
        return float(np.clip((zero - x) / (zero - full), 0.0, 1.0))
    return float(np.clip((x - zero) / (full - zero), 0.0, 1.0))


def _liveness(sig: dict[str, np.ndarray], f: _Findings, dead_abs: float,
              const_rtol: float, max_stuck_frac: float) -> None:
    for s, x in sig.items():
        amax = float(np.max(np.abs(x)))
        ptp = float(np.ptp(x))
        stuck = held_fraction(x)
        f.flags.update({f"{s}_ptp": ptp, f"{s}_held_frac": stuck,
                        f"{s}_dead": amax < dead_abs,
                        f"{s}_constant": ptp <= const_rtol * max(1.0, amax),
                        f"{s}_stuck": stuck > max_stuck_frac})
        if f.flags[f"{s}_dead"]:
            f.reasons.append(f"{s} dead (|{s}| < {dead_abs:g} throughout: failed tag?)")
        elif f.flags[f"{s}_constant"]:
            f.reasons.append(f"{s} constant (range {ptp:.3g})")
        elif f.flags[f"{s}_stuck"]:
            f.reasons.append(f"{s} stuck: unchanged in {_pct(stuck)} of steps")
        else:
            continue
        f.bad.add(s)


def _quantisation(sig: dict[str, np.ndarray], f: _Findings, warn_steps: float,
                  min_steps: float) -> tuple[dict[str, bool], dict[str, bool]]:
    motion_q: dict[str, bool] = {}
    coarse: dict[str, bool] = {}
    for s, x in sig.items():
        q = None if s in f.bad else estimate_quantum(x)
        steps = float(np.ptp(x) / q) if q else math.inf
        moves = np.abs(np.diff(x))
        moves = moves[moves > 0]
        move = float(np.median(moves)) if moves.size else 0.0
        # quantisation limits the sample-to-sample motion: holds are then expected
        motion_q[s] = bool(q) and move > 0 and q >= 0.5 * move
        # steps resolved to fewer than ~100 levels: equal successive steps (a "straight
        # line") then happen by chance
        coarse[s] = bool(q) and move > 0 and q >= 0.01 * move
        f.flags.update({f"{s}_quantum": q, f"{s}_steps": steps if q else None,
                        f"{s}_levels": int(np.unique(x).size),
                        f"{s}_quantised": bool(q) and steps < warn_steps,
                        f"{s}_motion_quantised": motion_q[s]})
        if not q:
            continue
        # score: log-linear from min_steps (0) to warn_steps (1)
        f.scores[f"{s}_quantisation"] = _ramp(math.log(max(steps, 1e-9)),
                                              math.log(warn_steps), math.log(min_steps))
        if steps < min_steps:
            f.reasons.append(f"{s} quantised too coarsely: {steps:.0f} steps of {q:.3g} "
                             f"across its range")
            f.bad.add(s)
        elif steps < warn_steps:
            f.warnings.append(f"{s} quantised: {steps:.0f} steps of {q:.3g} across its range")
    return motion_q, coarse


def _compression(sig: dict[str, np.ndarray], f: _Findings, motion_q: dict[str, bool],
                 coarse: dict[str, bool], warn_frac: float, max_frac: float,
                 linear_rtol: float) -> None:
    # Holds of a signal whose motion is limited by its quantum are expected without any
    # compression, so such signals are left out; when all are, compression cannot be
    # told from quantisation and is only reported. Straight runs are not sought in
    # signals whose steps are quantised (equal successive steps happen by chance).
    cont = [s for s in sig if not motion_q[s]]
    ambiguous = not cont
    use = list(sig) if ambiguous else cont
    held = held_fraction(*(sig[s] for s in use))
    lin_use = [s for s in use if not coarse[s]]
    lin = linear_fraction(*(sig[s] for s in lin_use), rtol=linear_rtol) if lin_use else 0.0
    comp = held + lin
    f.flags.update(held_frac=held, linear_frac=lin, compression_frac=comp,
                   compression_factor=(1.0 / (1.0 - comp)) if comp < 1 else math.inf,
                   compression_signals="+".join(use), compression_ambiguous=ambiguous,
                   compressed=(not ambiguous) and comp > warn_frac)
    for s in cont:
        own = own_holds(sig[s])
        f.flags[f"{s}_compressed_frac"] = own
        if own > warn_frac and not comp > warn_frac:
            f.warnings.append(f"historian compression of {s} alone: unchanged in "
                              f"{_pct(own)} of steps while the other signal moves (a held "
                              f"PV reads like a valve that does not move)")
    what = " and ".join(use)
    detail = f"held {_pct(held)}" + (f", linear {_pct(lin)}" if lin >= 0.005 else "")
    if ambiguous:
        if comp > warn_frac:
            f.warnings.append(f"{what} unchanged in {_pct(comp)} of steps ({detail}): "
                              f"expected from quantisation, not counted as compression")
        return
    f.scores["compression"] = _ramp(comp, warn_frac, max_frac)
    if comp > max_frac:
        f.reasons.append(f"historian fill in {_pct(comp)} of steps ({detail}; above "
                         f"{_pct(max_frac)} almost nothing is measured)")
    elif comp > warn_frac:
        f.warnings.append(f"historian compression: {what} unchanged or interpolated in "
                          f"{_pct(comp)} of steps ({detail}); held samples are treated "
                          f"as missing where the gaps are short")


def _interpolated(rec: Recording, f: _Findings, max_frac: float) -> None:
    notes = [str(w) for w in rec.meta.get("warnings", ())]
    n_interp = sum(int(m.group(1)) for w in notes for m in _INTERP.finditer(w))
    frac = n_interp / len(rec)
    f.flags.update(interpolated_values=n_interp, interpolated_frac=frac)
    f.scores["interpolated"] = _ramp(frac, 0.0, max_frac)
    if frac > max_frac:
        f.reasons.append(f"{n_interp} interpolated missing values ({_pct(frac)} of "
                         f"samples; limit {_pct(max_frac)})")
    elif n_interp:
        f.warnings.append(f"{n_interp} missing values interpolated")


def _saturation_aspect(op: np.ndarray, f: _Findings, sat_rtol: float, warn_frac: float,
                       max_frac: float) -> None:
    if "OP" in f.bad:
        f.flags["saturated"] = None
        return
    lo_f, hi_f = _saturation(op, sat_rtol)
    sat = max(lo_f, hi_f)
    f.flags.update(OP_sat_low_frac=lo_f, OP_sat_high_frac=hi_f, OP_sat_frac=sat,
                   OP_min=float(op.min()), OP_max=float(op.max()), saturated=sat > warn_frac)
    f.scores["saturation"] = _ramp(sat, warn_frac, max_frac)
    side, v = ("minimum", op.min()) if lo_f >= hi_f else ("maximum", op.max())
    if sat > max_frac:
        f.reasons.append(f"OP saturated at its {side} ({v:.4g}) for {_pct(sat)} of samples")
    elif sat > warn_frac:
        f.warnings.append(f"OP saturated at its {side} ({v:.4g}) for {_pct(sat)} of "
                          f"samples: the loop is open that long")


def _normalisation(sig: dict[str, np.ndarray], f: _Findings, mean_rtol: float,
                   unit_std_tol: float) -> None:
    means = {s: float(np.mean(x)) for s, x in sig.items()}
    stds = {s: float(np.std(x)) for s, x in sig.items()}
    for s in sig:
        f.flags[f"{s}_mean"] = means[s]
        f.flags[f"{s}_std"] = stds[s]
    live = [s for s in sig if s not in f.bad]
    mean_removed = bool(live) and all(abs(means[s]) <= mean_rtol * stds[s] for s in live)
    unit_var = bool(live) and all(abs(stds[s] - 1.0) <= unit_std_tol for s in live)
    f.flags.update(mean_removed=mean_removed, unit_variance=unit_var,
                   normalised=mean_removed or unit_var)
    if f.flags["normalised"]:
        kind = ("mean-removed, unit variance" if mean_removed and unit_var
                else "mean-removed" if mean_removed else "unit variance")
        f.warnings.append(f"data normalised ({kind}): absolute levels such as valve "
                          f"saturation cannot be judged")


def _length(rec: Recording, sig: dict[str, np.ndarray], f: _Findings, target: str,
            min_periods: float, warn_samples: int) -> None:
    n = len(rec)
    f.flags.update(pv_period_samples=None, n_periods=None, few_periods=False,
                   short=n < warn_samples)
    f.scores["length"] = min(1.0, n / warn_samples)
    if n < warn_samples:
        f.warnings.append(f"short record: {n} samples")
    if target in f.bad:
        return
    from ..estimators.oscillation import acf_oscillation

    try:
        res = acf_oscillation(sig[target], rec.Ts, max_lag=n - 1)
    except InputError:
        return
    if res.oscillating:
        periods = n / res.period_samples
        f.flags.update(pv_period_samples=float(res.period_samples),
                       n_periods=float(periods), few_periods=periods < min_periods)
        f.scores["periods"] = min(1.0, periods / min_periods)
        if periods < min_periods:
            f.warnings.append(f"only {periods:.1f} periods of the {target} oscillation "
                              f"(period {res.period:.4g} s) in the record; at least "
                              f"{min_periods:g} are needed")


def _pairing(rec: Recording, f: _Findings, alpha: float) -> None:
    """Haugh's test that OP and PV are independent (the diagnosis's pairing test,
    :func:`stictionbench.diagnosis.routes.pairing_test`): a warning where it cannot
    reject that, no score (``reports/diagnose/pairing_check.md``)."""
    f.flags["op_pv_independence_p"] = None
    if f.reasons or f.bad:
        return
    from ..diagnosis.routes import pairing_test

    t = pairing_test(rec, alpha)
    f.flags["op_pv_independence_p"] = float(t["p_value"])
    if t["independent"]:
        f.warnings.append(f"OP and PV independent (Haugh's test p = {t['p_value']:.2g}): "
                          "a tag of another loop, or a frozen PV?")


def grade(score: float, usable: bool) -> str:
    """``good`` (score ≥ 0.8), ``fair`` (≥ 0.5), ``poor`` or ``unusable``.

    Examples
    --------
    >>> grade(0.9, True), grade(0.6, True), grade(0.1, True), grade(1.0, False)
    ('good', 'fair', 'poor', 'unusable')
    """
    if not usable:
        return "unusable"
    return "good" if score >= 0.8 else "fair" if score >= 0.5 else "poor"


def screen(
    rec: Recording,
    *,
    dead_abs: float = 1e-30,
    const_rtol: float = 1e-9,
    max_stuck_frac: float = 0.95,
    warn_compression_frac: float = HOLD_WARN,
    max_compression_frac: float = 0.9,
    linear_rtol: float = 1e-6,
    warn_quant_steps: float = 100.0,
    min_quant_steps: float = 5.0,
    warn_sat_frac: float = 0.2,
    max_sat_frac: float = 0.8,
    sat_rtol: float = 0.005,
    mean_rtol: float = 1e-3,
    unit_std_tol: float = 0.02,
    max_interpolated_frac: float = 0.5,
    min_periods: float = 3.0,
    warn_samples: int = 500,
    pairing_alpha: float = 0.05,
) -> QualityReport:
    """Screen a Recording's data quality before any diagnosis: a graded score, and
    ``unusable`` only for data that cannot support a verdict.

    Each aspect scores 1 (no problem) to 0 between its warning level and its limit;
    ``flags["score"]`` is their product and ``flags["grade"]`` reads it (good ≥ 0.8,
    fair ≥ 0.5, poor). Past a limit the record is unusable, with the reason.

    Parameters
    ----------
    rec : Recording
        The record. With ``meta["op_only"]`` (OP-only benchmark loops, PV = OP) the PV
        rules are skipped.
    dead_abs, const_rtol, max_stuck_frac : float
        Dead (``max|x| < dead_abs``, a failed tag), constant, or unchanged over more than
        ``max_stuck_frac`` of steps: unusable.
    warn_compression_frac, max_compression_frac : float
        Historian fill (``held_frac + linear_frac``): warning and score falling from 1
        above 0.1, unusable above 0.9 (almost nothing measured); see the module notes.
    linear_rtol : float
        Relative tolerance on the second difference for :func:`linear_fraction`.
    warn_quant_steps, min_quant_steps : float
        Quantisation steps across a signal's range: warning below 100, score falling
        log-linearly to 0 at 5, unusable below 5 (no shape is resolved).
    warn_sat_frac, max_sat_frac, sat_rtol : float
        OP within ``sat_rtol·range`` of its minimum or maximum: warning above 20 % of
        samples, unusable above 80 % (the loop is open nearly throughout).
    mean_rtol, unit_std_tol : float
        Mean-removed or unit-variance data: flag and warning only.
    max_interpolated_frac : float
        Interpolated missing values (``meta["warnings"]``): score falling to 0 at 50 %,
        unusable above.
    min_periods : float
        Fewer periods of the PV's regular oscillation: warning, score ``periods/3``.
    warn_samples : int
        Fewer samples: warning, score ``n/500``.
    pairing_alpha : float
        OP and PV independent by Haugh's test at this level (:func:`_pairing`): warning
        only (a wrong tag, or a frozen PV), ``flags["op_pv_independence_p"]``.

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
    >>> rep.usable, rep.reasons, rep.flags["grade"]
    (False, ['PV dead (|PV| < 1e-30 throughout: failed tag?)'], 'unusable')
    """
    op_only = bool(rec.meta.get("op_only", False))
    names = ("OP",) if op_only else ("PV", "OP")
    sig = {s: np.asarray(getattr(rec, s), dtype=float) for s in names}
    n = len(rec)
    f = _Findings({"n": n, "Ts": float(rec.Ts), "duration_s": float(n * rec.Ts),
                   "op_only": op_only})
    _liveness(sig, f, dead_abs, const_rtol, max_stuck_frac)
    motion_q, coarse = _quantisation(sig, f, warn_quant_steps, min_quant_steps)
    _compression(sig, f, motion_q, coarse, warn_compression_frac, max_compression_frac,
                 linear_rtol)
    _interpolated(rec, f, max_interpolated_frac)
    _saturation_aspect(sig["OP"], f, sat_rtol, warn_sat_frac, max_sat_frac)
    _normalisation(sig, f, mean_rtol, unit_std_tol)
    _length(rec, sig, f, "OP" if op_only else "PV", min_periods, warn_samples)
    if not op_only:
        _pairing(rec, f, pairing_alpha)
    usable = not f.reasons
    score = float(np.prod(list(f.scores.values()))) if usable else 0.0
    f.flags.update(score=score, grade=grade(score, usable),
                   **{f"score_{k}": v for k, v in f.scores.items()})
    name = str(rec.meta.get("name") or rec.meta.get("source", ""))
    return QualityReport(usable=usable, reasons=f.reasons, flags=jsonable(f.flags),
                         warnings=f.warnings, name=name)


def release_holds(rec: Recording, max_gap: int | None = None, *,
                  joint: bool = True,
                  signals: tuple[str, ...] = ("PV", "OP")) -> tuple[Recording, int]:
    """Historian holds treated as missing: held samples are replaced by a straight line
    between the measured samples around them — only where the gap is at most
    ``max_gap`` samples (default: 2 % of the record, at least 3); longer holds are kept
    (the data do not support a guess).

    ``joint=True`` (what :func:`prepare` does): a held sample is one where PV and OP are
    both exactly unchanged, and every recorded signal is bridged there. During a
    valve's stick phase OP keeps moving, so a stick is never a PV-and-OP hold.
    ``joint=False``: each of ``signals`` is bridged over its own holds, as if each tag
    had been compressed on its own. For box-car (exception) compression this is not the
    better reconstruction: the held value is within the dead band of the truth, the line
    is not, and a stick followed by a slip becomes a ramp
    (``experiments/compression.py`` measures both).

    Returns the new recording and the number of samples in which any signal was filled;
    the recording's ``meta[FILLED]`` marks those samples (a boolean mask, a sample in
    which any signal was filled), so that a method reading sample-to-sample changes can
    read the change across each gap instead of the line's steps
    (:class:`~stictionbench.estimators.yamashita.Yamashita`).

    Examples
    --------
    >>> t = np.arange(200.0)
    >>> pv = np.repeat(np.arange(100.0), 2)
    >>> rec, k = release_holds(Recording.from_arrays(t, pv, pv))
    >>> k, float(rec.PV[1])
    (99, 0.5)
    >>> release_holds(Recording.from_arrays(t, pv, t))[1]
    0
    >>> rec, k = release_holds(Recording.from_arrays(t, pv, t), joint=False)
    >>> k, float(rec.PV[1]), float(rec.OP[1])
    (99, 0.5, 1.0)
    """
    import dataclasses

    n = len(rec)
    limit = max(3, int(HOLD_SHARE * n)) if max_gap is None else int(max_gap)
    k = np.arange(n)
    fills: dict[str, np.ndarray] = {}
    if joint:
        held = np.zeros(n, bool)
        held[1:] = ((np.diff(np.asarray(rec.PV, float)) == 0)
                    & (np.diff(np.asarray(rec.OP, float)) == 0))
        fill = _short_runs(held, limit)
        fills = {s: fill for s in ("PV", "OP", "SP", "MV") if getattr(rec, s) is not None}
    else:
        for s in signals:
            x = getattr(rec, s, None)
            if x is not None:
                held = np.zeros(n, bool)
                held[1:] = np.diff(np.asarray(x, float)) == 0
                fills[s] = _short_runs(held, limit)
    fills = {s: f for s, f in fills.items() if f.any()}
    if not fills:
        return rec, 0
    changes = {s: np.interp(k, k[~f], np.asarray(getattr(rec, s), float)[~f])
               for s, f in fills.items()}
    mask = np.logical_or.reduce(list(fills.values()))
    filled = int(mask.sum())
    meta = {**rec.meta, "holds_released": filled, FILLED: mask}
    return dataclasses.replace(rec, meta=meta, **changes), filled


def _short_runs(held: np.ndarray, limit: int) -> np.ndarray:
    """The ``held`` samples in runs of at most ``limit`` that end at a measured sample
    (a line needs a point to go to)."""
    n = held.size
    fill = np.zeros(n, bool)
    i = 1
    while i < n:
        if not held[i]:
            i += 1
            continue
        j = i
        while j < n and held[j]:
            j += 1
        if j < n and j - i <= limit:
            fill[i:j] = True
        i = j
    return fill


def own_holds(x: np.ndarray, rtol: float = 0.005) -> float:
    """Share of steps in which ``x`` is exactly unchanged away from its observed minimum
    and maximum (within ``rtol`` of its range): a signal pinned at a limit (a saturated
    OP) holds for a physical reason, not because a historian compressed it.

    Examples
    --------
    >>> own_holds(np.array([0.0, 0, 1, 1, 2, 3, 3, 3]))
    0.142857...
    """
    x = np.asarray(x, float)
    if x.size < 2:
        return 0.0
    lo, hi = float(np.min(x)), float(np.max(x))
    tol = rtol * (hi - lo)
    inside = (x[1:] > lo + tol) & (x[1:] < hi - tol)
    return float(np.mean((np.diff(x) == 0) & inside))


def prepare(rec: Recording) -> tuple[Recording, QualityReport, int]:
    """Screen a recording and, when it is compressed, treat its held samples as missing
    (:func:`release_holds`, PV-and-OP holds); returns the recording to analyse, the
    screen of the original and the number of samples filled."""
    q = screen(rec)
    if q.usable and q.flags.get("compressed"):
        out, k = release_holds(rec)
        return out, q, k
    return rec, q, 0
