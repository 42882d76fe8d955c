"""Validation: the evidence that decides which physics is missing.

Each fitted hypothesis is its deterministic physics plus a noise model ``H`` on the output
error (:mod:`.noise`). All hypotheses of one recording are judged under the *same* noise
model — the AR (or integrated AR) model of the output error of the hypothesis that fits
the training data best — so that an effect one model leaves unexplained is not absorbed
into its own, more flexible, noise model (Ljung, *System Identification*, 1999, ch. 7,
16.4–16.6: prediction-error criteria, model-structure tests and residual analysis):

- **against the nominal model** (every hypothesis contains it): the likelihood ratio of the
  one-step prediction errors on the *validation* blocks, ``N·ln(V₀/V₁)``, against χ² with
  the number of extra parameters, and the same on the ``k``-step-ahead errors with ``k``
  the loop's time scale ``τ + θ`` (``N/k`` effective samples: a mismatch slower than the
  noise model's memory is predicted away one step ahead, not ``k`` steps ahead); the
  smaller p-value, Bonferroni-corrected, is the hypothesis's p-value. A hypothesis is
  *significant* when that p-value is below ``alpha``, its simulation NRMSE on the
  validation blocks improves by at least ``min_improvement`` and its fit is not on an end
  of a search-limited range (``at_bound``: the oscillation period); a hypothesis whose
  ``at_bound`` is itself the data's resolution in its own unit (a dead time more than one
  sample from the nominal) need only improve the NRMSE at all (:func:`passes`) — against
  a given model, on a recording with set-point excitation (:func:`.diagnose.
  own_resolution`: on regulatory data a delay fitted from closed-loop OP and PV is
  biased by the load OP answers, a true 1 s read as 19–58 s improving the NRMSE 2–9 %
  with p < 0.01 given the true model; without a model the nominal's dead time is itself
  identified); otherwise the dead time meets the ``min_improvement`` gate like every
  other hypothesis. A dead time named on that exemption alone gives way to a sensor lag
  that meets the same standard with the lower BIC (:func:`_rival_on_own_standard`);
- **the process re-identified** (no model given): a valve hypothesis must also beat the
  linear loop refitted under the same criterion (the Hammerstein identification's own
  likelihood-ratio test); its p-value is the larger of the two (an intersection–union
  test);
- **across families**: among the significant ones, the lowest BIC of the innovations on
  the training plus the validation blocks wins;
- **nested physics**: stiction contains the dead band (``J = 0``): when either is
  named, stiction is named only when the ``1 − alpha`` interval of the slip jump
  ``J`` excludes zero (the likelihood-ratio test of ``J = 0``), the fitted ``J`` is
  at least :data:`MIN_SLIP_FRACTION` of ``S`` (a resolution: with thousands of samples a
  slip of a few per cent of ``S`` becomes "significant" against the small model error
  of any discrete replay) and the stiction fit itself passes its likelihood-ratio test
  against the nominal model on the validation blocks (the ``J`` interval comes from the
  training blocks);
- **the oscillation explained from inside the loop**: when the identified valve, closed
  with the loop's PI, reproduces the recorded oscillation's period, PV and OP amplitudes
  and waveform by itself (:mod:`.cycle`), a significant valve hypothesis is named over the
  other significant ones (:func:`select`);
- **residual analysis** of the named model: Ljung–Box whiteness of its innovations and
  their independence from past OP (pre-whitened by its own AR model; lag 0 left out,
  since in closed loop OP reacts to the current PV). The innovations are the named
  model's output error whitened by a noise model of its own, fitted on the training
  blocks from the family :data:`RESIDUAL_NOISE_FAMILY` (AR, ARMA and their integrated
  forms by BIC): reported only, they decide nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.stats import chi2

from .cycle import CycleCheck
from .fit import Fit, noise_source
from .hammerstein import MIN_SLIP_FRACTION, SLIP_JUMP_ASYMPTOTIC
from .hypotheses import HYPOTHESES, Nominal
from .noise import NoiseModel, fit_noise_model, input_independence, ljung_box, lr_test
from .openloop import band_of, likelihood_highpass

#: test level of the likelihood-ratio tests (and of the slip-jump interval) and the least
#: relative improvement of the validation NRMSE, from the tuning rule of the three-family
#: concealed benchmark (``experiments/concealed.py``, all families pooled, in-sample:
#: most recordings named with ``none`` called physics ≤ 5 %; its grid runs to alpha 0.1
#: and an improvement of 0.2, past both picks). With the prediction-error fits the rule
#: picked alpha = 0.05 on the pooled data and on two of the three leave-one-family-out
#: folds (0.03 with ``sim_physical`` held out). Since Choudhury's restart was added to the
#: valve identification against a given model it picks 0.03 on the pooled data and on
#: every fold: 0.03 and 0.05 name the same 208 of 240 there (``none`` called physics 0
#: of 72 with both), the rule breaks the tie towards the smaller alpha, and 0.05 was kept
#: (the blind holdout block of ``holdout_fresh.md`` was scored with it). For the
#: improvement it picks 0.1 (for a
#: while, after the dead-time alignment rule, it picked 0.05, which named one recording
#: more of 240 and called physics in 3 of 72 ``none`` recordings against 0; 0.1 was
#: kept then). The summary in
#: ``reports/concealed/`` recomputes both on every run; its leave-one-family-out numbers
#: are the out-of-sample estimate. (Output-error fits: the rule picked 0.001 and 0.1.)
#: When the comparison band became causal (``openloop.comparison_band``), the rule on the
#: three families' causal evidence picked alpha 0.1 (``causal_filter.md``); both 0.05 and
#: 0.1 were scored with the causal band on holdout blocks neither had seen
#: (``causal_blind.md``: the same level-2 score, 5 and 6 of 192 healthy loops called
#: physics), and 0.05, the variant the switch was stated for, was kept.
ALPHA = 0.05
MIN_IMPROVEMENT = 0.1
#: the nested valve family (stiction contains the dead band, ``J = 0``), fitted by the
#: closed-loop Hammerstein identification and decided between by the slip-jump test
VALVE_HYPOTHESES = ("stiction", "deadband")
#: hypotheses whose practical significance is a resolution in their own parameter
#: (:attr:`.Hypothesis.own_resolution`): the dead time
OWN_RESOLUTION = frozenset(n for n, h in HYPOTHESES.items() if h.own_resolution)
#: hypotheses whose evidence sits where OP goes — a travel limit, the valve's installed
#: curve — rather than in every move: few of the episodes that carry it may fall in the
#: validation blocks (``reports/concealed/saturation_evidence.md``)
RANGE_HYPOTHESES = ("saturation", "valve_characteristic")
#: level of the full-data likelihood-ratio test (:func:`_full_data_p`) by which a range
#: hypothesis is named where nothing else was (:func:`range_fallback`): in-sample for its
#: training part and a supremum over a limit or curvature that the χ² reference does not
#: cover, hence far below :data:`ALPHA`. Set on the three tuning families by
#: ``experiments/decision_rules.py`` (``range_fallback``: most named with ``none`` called
#: physics ≤ 5 % over 1e-4 … 1e-12, ties to the smaller level), scored on the others
FULL_DATA_ALPHA = 1e-10
#: independent samples the validation blocks hold in the comparison band
#: (:func:`band_dof`) at and above which the NRMSE gate is :data:`MIN_IMPROVEMENT`
#: itself; below, the gate grows as ``1/√dof`` (:func:`scaled_gate`). Read off
#: ``reports/concealed/slow_loops.md`` (healthy loops of the holdout family, their speed
#: varied, the gate unscaled: called physics through the gate 0 of 336 at 100 or more, 28
#: of 384 below; OP held at its limit, named from OP, aside), scored on the holdout
#: family's blind block 14000 and on the other benchmarks
BAND_DOF = 100.0
#: noise-model family of the residual analysis (:func:`_residual_tests`; reported, no
#: verdict depends on it). On loops simulated with exactly the model the diagnosis is
#: given and a drifting load, Ljung–Box rejected whiteness of innovations whitened by the
#: AR family on 75 of 90 and by the ARMA family on 20 of 90
#: (``reports/diagnose/residual_tests_calibration.md``): white measurement noise on a
#: drifting load is an ARMA, which a short AR does not whiten
RESIDUAL_NOISE_FAMILY = "arma"


@dataclass
class Verdict:
    """The outcome of :func:`validate`."""

    pick: str
    ranking: list[dict[str, Any]]
    tests: dict[str, Any]
    noise: NoiseModel
    innovations: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    variances: dict[str, dict[str, float]] = field(default_factory=dict)
    #: the hypotheses judged by their own resolution in this verdict (:func:`passes`)
    own_resolution: frozenset[str] = OWN_RESOLUTION
    #: each hypothesis's high-passed output error (:func:`output_error`) and the training
    #: samples: what the residual analysis whitens (:func:`_residual_tests`)
    output_errors: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    train: np.ndarray | None = field(default=None, repr=False)


def output_error(fit: Fit, pv: np.ndarray, Ts: float, f_hp: float,
                 highpass_order: int = 2) -> np.ndarray:
    """High-passed (not low-passed) output error of a fitted hypothesis: the series its
    noise model describes. Against a given model ``highpass_order`` 1 or 0 replaces the
    comparison band's second-order high-pass by a first-order one or none
    (:func:`.openloop.likelihood_highpass`); without a model the zero-phase band stays."""
    h = HYPOTHESES.get(fit.name, Nominal())
    if highpass_order != 2 and fit.ctx.model_given:
        X = h.regressors(fit.ctx, fit.p)
        X = X if X.ndim == 2 else X[:, None]
        return likelihood_highpass(np.asarray(pv, float) - X @ fit.beta, Ts, f_hp, highpass_order)
    band = band_of(fit.ctx.model_given)
    X = band(h.regressors(fit.ctx, fit.p), Ts, f_hp)
    X = X if X.ndim == 2 else X[:, None]
    return band(pv, Ts, f_hp) - X @ fit.beta


def _scores(fits: dict[str, Fit], e: dict[str, np.ndarray], train: np.ndarray,
            val: np.ndarray) -> dict[str, dict[str, float]]:
    out = {}
    for name, ft in fits.items():
        v_tr = float(np.mean(e[name][train] ** 2))
        v_val = float(np.mean(e[name][val] ** 2))
        k = ft.n_params
        bic = (train.size * math.log(max(v_tr, 1e-300)) + k * math.log(train.size)
               + val.size * math.log(max(v_val, 1e-300)) + k * math.log(val.size))
        out[name] = {"train": v_tr, "validation": v_val, "bic": bic}
    return out


def _slip_jump_test(fits: dict[str, Fit], var: dict[str, dict[str, float]],
                    n_train: int) -> dict[str, Any]:
    """LR test of ``J = 0``: from the closed-loop valve identification when it ran
    (its profile likelihood), else stiction against the dead band (its ``J = 0`` case)
    on the training innovations."""
    st = fits["stiction"].extra.get("slip_jump_zero")
    if st is not None:
        return {"method": SLIP_JUMP_ASYMPTOTIC, **st}
    return {**lr_test(var["deadband"]["train"], var["stiction"]["train"], n_train, 1),
            "method": SLIP_JUMP_ASYMPTOTIC}


def _against_nominal(name: str, ft: Fit, base: Fit, var: dict[str, dict[str, float]],
                     ek: dict[str, np.ndarray], val: np.ndarray,
                     horizon: int) -> dict[str, float]:
    """LR tests of a hypothesis against the nominal model on the validation blocks: on
    one-step innovations (``N·ln(V₀/V₁)``) and on ``horizon``-step prediction errors
    (``(N/horizon)·ln(V₀ₖ/V₁ₖ)``: overlapping k-step errors carry about ``N/k``
    independent samples); ``p_value`` is the smaller p-value, Bonferroni-corrected."""
    df = max(1, ft.n_params - base.n_params)
    one = lr_test(var["none"]["validation"], var[name]["validation"], val.size, df)
    if horizon <= 1:
        return {**one, "p_one_step": one["p_value"], "p_k_step": one["p_value"]}
    vk0 = float(np.mean(ek["none"][val] ** 2))
    vk1 = float(np.mean(ek[name][val] ** 2))
    kst = lr_test(vk0, vk1, max(1, val.size // horizon), df)
    p = min(1.0, 2.0 * min(one["p_value"], kst["p_value"]))
    stat = one["statistic"] if one["p_value"] <= kst["p_value"] else kst["statistic"]
    return {"statistic": stat, "p_value": p, "df": df, "p_one_step": one["p_value"],
            "p_k_step": kst["p_value"]}


def _full_data_p(name: str, ft: Fit, base: Fit, var: dict[str, dict[str, float]],
                 n_train: int, n_val: int) -> float:
    """The classic prediction-error test of a hypothesis against the nominal model on
    every block, training and validation (Ljung 1999, ch. 16.4: ``N·ln(V₀/V₁)`` against
    χ² with the extra parameters; the training part is Wilks's statistic, the validation
    part out of sample). Reported beside the validation test, not used in the decision:
    ``experiments/decision_rules.py`` (``full_data_lr``) scores a rule that decides by it.
    A valve whose process was re-identified keeps the intersection–union gate."""
    df = max(1, ft.n_params - base.n_params)
    stat = sum(lr_test(var["none"][part], var[name][part], n, df)["statistic"]
               for n, part in ((n_train, "train"), (n_val, "validation")))
    p = float(chi2.sf(max(stat, 0.0), df))
    return p if ft.gate_p is None else max(p, ft.gate_p)


def validate(fits: dict[str, Fit], pv: np.ndarray, op: np.ndarray, Ts: float, f_hp: float,
             train: np.ndarray, val: np.ndarray, *, alpha: float,
             min_improvement: float, horizon: int = 1,
             cycle: CycleCheck | None = None,
             own_resolution: frozenset[str] = OWN_RESOLUTION,
             highpass_order: int = 2, noise_family: str = "ar") -> Verdict:
    """Decide among fitted hypotheses (``fits["none"]`` is the nominal model) by
    prediction-error likelihood; see the module docstring. ``horizon`` (samples) adds
    the k-step-ahead test (the loop's time scale ``τ + θ``); ``cycle`` is the closed-loop
    cycle check of the identified valve (:mod:`.cycle`), reported under ``tests`` and
    passed to :func:`select`; ``own_resolution`` the hypotheses whose practical
    significance is their own resolution (:func:`passes`); ``highpass_order`` the
    high-pass of the output errors whitened (:func:`output_error`); ``noise_family`` that
    of the noise model (:func:`.noise.fit_noise_model`)."""
    oe = {name: output_error(ft, pv, Ts, f_hp, highpass_order) for name, ft in fits.items()}
    src = noise_source(fits)
    src_oe = next((oe[k] for k, ft in fits.items() if ft is src), None)
    noise = fit_noise_model((output_error(src, pv, Ts, f_hp, highpass_order)
                             if src_oe is None else src_oe)[train], family=noise_family)
    e = {name: noise.whiten(r) for name, r in oe.items()}
    ek = {name: noise.kstep(r, horizon) for name, r in oe.items()} if horizon > 1 else {}
    var = _scores(fits, e, train, val)
    base = fits["none"]
    # the k-step (one-step when the horizon is 1) prediction errors on the validation
    # blocks: an effect size a slow load barely enters (reported; the gate is the NRMSE)
    pk = ek if ek else e
    vk = {name: float(np.mean(pk[name][val] ** 2)) for name in fits}
    rows = []
    for name, ft in fits.items():
        if name == "none":
            lr = {"statistic": 0.0, "p_value": 1.0, "df": 0, "p_one_step": 1.0,
                  "p_k_step": 1.0}
            improvement, p_full = 0.0, 1.0
        else:
            lr = _against_nominal(name, ft, base, var, ek, val, horizon)
            p_full = _full_data_p(name, ft, base, var, train.size, val.size)
            if ft.gate_p is not None:
                # intersection–union test: significant only when both tests are
                lr = {**lr, "p_value": max(lr["p_value"], ft.gate_p)}
            improvement = 1.0 - ft.nrmse_val / max(base.nrmse_val, 1e-300)
        row = {"physics": name, "raw_score": var[name]["bic"],
               "p_value": lr["p_value"], "lr_statistic": lr["statistic"],
               "df": lr["df"], "p_one_step": lr["p_one_step"],
               "p_k_step": lr["p_k_step"], "p_gate": ft.gate_p, "p_full": p_full,
               "improvement": improvement, "nrmse_validation": ft.nrmse_val,
               "improvement_kstep": 1.0 - math.sqrt(vk[name] / max(vk["none"], 1e-300)),
               "innovation_variance": var[name]["validation"],
               "parameters": ft.params, "at_bound": ft.at_bound}
        rows.append({**row, "significant": passes(row, alpha, min_improvement,
                                                  own_resolution=own_resolution)})
    tests: dict[str, Any] = {}
    if set(VALVE_HYPOTHESES) <= set(fits):
        tests["slip_jump_zero"] = _slip_jump_test(fits, var, train.size)
    if cycle is not None:
        tests["closed_loop_cycle"] = cycle.to_dict()
    pick = select(rows, tests.get("slip_jump_zero", {}).get("p_value"), alpha=alpha,
                  min_improvement=min_improvement, own_resolution=own_resolution,
                  cycle_reproduced=bool(cycle is not None and cycle.reproduced))
    model_given = next(iter(fits.values())).ctx.model_given
    return Verdict(pick, _ranking(rows), _residual_tests(tests, rows, pick, oe, train, op, Ts,
                                                         f_hp, val, model_given=model_given),
                   noise, e, var, own_resolution, oe, train)


def failed_gates(row: dict[str, Any], alpha: float, min_improvement: float, *,
                 own_resolution: frozenset[str] = OWN_RESOLUTION) -> list[str]:
    """The gates of :func:`passes` one hypothesis's row fails, in words (empty when it is
    significant): its fit on an end of a search-limited range (``at_bound``), its p-value
    at or above ``alpha``, its validation NRMSE improving by less than
    ``min_improvement`` — or, for a hypothesis in ``own_resolution``, not at all (its
    ``at_bound`` already withholds the effects the data do not resolve: a dead time
    within one sample of the nominal). The nominal model itself is never significant."""
    if row["physics"] == "none":
        return ["the nominal model"]
    why = []
    if row.get("at_bound", False):
        why.append("fit on the end of its search range")
    if row["p_value"] >= alpha:
        why.append(f"p ≥ {alpha:g}")
    if row["physics"] in own_resolution:
        if row["improvement"] <= 0.0:
            why.append("no NRMSE improvement")
    elif row["improvement"] < min_improvement:
        why.append(f"NRMSE improvement < {min_improvement:.0%}")
    return why


def passes(row: dict[str, Any], alpha: float, min_improvement: float, *,
           own_resolution: frozenset[str] = OWN_RESOLUTION) -> bool:
    """Whether one hypothesis's row is significant: it fails none of the gates of
    :func:`failed_gates`."""
    return not failed_gates(row, alpha, min_improvement, own_resolution=own_resolution)


def select(rows: list[dict[str, Any]], slip_jump_p: float | None, *, alpha: float,
           min_improvement: float, min_slip_fraction: float = MIN_SLIP_FRACTION,
           own_resolution: frozenset[str] = OWN_RESOLUTION,
           cycle_reproduced: bool = False, rivals_on_own_standard: bool = True) -> str:
    """The decision rule alone, from each row's ``physics``, ``p_value`` (LR against the
    nominal model), ``improvement`` (validation NRMSE), ``at_bound`` (a fit on the end of
    a search-limited range, never named) and ``raw_score`` (BIC; or the
    ranking's ``score``, the same up to a constant), and the
    p-value of ``J = 0``: the significant hypothesis of lowest BIC; stiction and dead band
    (nested) by the slip-jump test when either is the pick (stiction when ``J = 0`` is
    rejected and the fitted ``J`` is at least ``min_slip_fraction`` of ``S``). Benchmarks
    re-run it to set the thresholds on one generator family and test on another;
    ``own_resolution`` (:func:`passes`) is there for the ablation that names it empty.

    ``cycle_reproduced`` (the identified valve, closed with the loop's PI, reproduces the
    recorded oscillation by itself: :mod:`.cycle`) names a significant valve hypothesis
    over any other significant one, whatever their BIC: the oscillation is then explained
    without an external source, a prediction nothing was fitted to, where an external
    line, a relay-like travel limit or a curve fitted from OP describe it only as well.
    It never makes a valve significant by itself.

    ``rivals_on_own_standard``: a pick named on its own resolution only (it would fail the
    ``min_improvement`` gate) is compared with its rivals on that same standard
    (:func:`_rival_on_own_standard`)."""
    sig = {r["physics"] for r in rows
           if passes(r, alpha, min_improvement, own_resolution=own_resolution)}
    pick = min((r for r in rows if r["physics"] in sig), key=_bic,
               default={"physics": "none"})["physics"]
    if rivals_on_own_standard:
        pick = _rival_on_own_standard(rows, pick, alpha, min_improvement, own_resolution)
    valves = [r for r in rows if r["physics"] in sig and r["physics"] in VALVE_HYPOTHESES]
    if cycle_reproduced and valves:
        pick = min(valves, key=_bic)["physics"]
    # the nested pair is one family: once either member is named, the slip-jump test
    # decides between them, whichever of the two passed its own test against the nominal
    # (a dead band whose stiction extension needs J ≠ 0 is stiction)
    # — and stiction must also beat the nominal model on its own likelihood-ratio test
    # (a dead band named while the stiction fit does not beat the nominal is not stiction,
    # however its training fit resolves J)
    if pick in VALVE_HYPOTHESES and slip_jump_p is not None:
        row = next(r for r in rows if r["physics"] == "stiction")
        st = row["parameters"]
        big = st.get("J", 0.0) >= min_slip_fraction * st.get("S", 0.0)
        own = row["p_value"] < alpha and not row.get("at_bound", False)
        # ≤: a Monte Carlo p-value (diagnose --slip-jump-bootstrap) rejects at level α
        # when it is ≤ α (Davison & Hinkley 1997, ch. 4.2); χ²'s is never exactly α
        pick = "stiction" if slip_jump_p <= alpha and big and own else "deadband"
    return pick


#: the rivals of a hypothesis named on its own resolution: other forms of the same
#: physics (a sensor lag is a lag on PV, as a dead time is)
RIVALS = {"dead_time": ("sensor_lag",)}


def _rival_on_own_standard(rows: list[dict[str, Any]], pick: str, alpha: float,
                           min_improvement: float, own_resolution: frozenset[str]) -> str:
    """``pick``, or the rival that meets the standard ``pick`` was named on and has the
    lower BIC. A hypothesis in ``own_resolution`` (the dead time) is named when it
    improves the validation NRMSE at all; the other hypotheses need ``min_improvement``.
    Where the dead time passes only by that exemption, a rival explanation of the same
    resolved mismatch (a sensor lag: a first-order lag on PV that a delay approximates)
    that meets the same standard (p below ``alpha``, a positive NRMSE improvement, not on
    an end of its range) and has the lower BIC is the better-supported answer; the gate
    that kept it out was not the one the named hypothesis met. Unchanged when ``pick``
    meets the ``min_improvement`` gate like every other hypothesis, so the rule never
    names physics where the shipped gates named none."""
    row = next((r for r in rows if r["physics"] == pick), None)
    if row is None or pick not in own_resolution or \
            passes(row, alpha, min_improvement, own_resolution=frozenset()):
        return pick
    rivals = [r for r in rows if r["physics"] in RIVALS.get(pick, ())
              and passes(r, alpha, 0.0, own_resolution=frozenset())
              and r["improvement"] > 0.0 and _bic(r) < _bic(row)]
    return min(rivals, key=_bic)["physics"] if rivals else pick


def slow_line_named(pick: str, row: dict[str, Any] | None, corner_period_s: float, *,
                    alpha: float, min_improvement: float) -> bool:
    """Whether the second look's oscillatory disturbance (:func:`.diagnose.second_look`:
    the line fitted again in a band whose slow-load high-pass is a third as high) is
    named: only where the main band named nothing (``pick`` is ``none``), only a line
    slower than the main band's high-pass corner period ``corner_period_s`` (a line the
    main band attenuates; a faster one the main band saw as well) and only when it passes
    the gates of :func:`passes` in its own band. In the wide band a slow load and the slow
    part of other physics enter too: where the main band names a hypothesis, the wide
    band's slow line is not preferred to it (``experiments/slow_line.py`` scores both)."""
    if pick != "none" or row is None or row.get("physics") != "oscillatory_disturbance":
        return False
    period = float(row.get("parameters", {}).get("period", 0.0))
    return period > corner_period_s and passes(row, alpha, min_improvement)


def after_second_look(pick: str, look: dict[str, Any] | None, *, alpha: float,
                      min_improvement: float) -> str:
    """``pick`` (a main-band verdict), or the oscillatory disturbance where the second
    look's line is named (:func:`slow_line_named`); ``look`` is a diagnosis's
    ``details["slow_line"]`` (``None``: the look did not run). For re-deciding a
    diagnosis by another main-band rule with the look kept as shipped."""
    if look and slow_line_named(pick, look["oscillatory_disturbance"],
                                look["corner_period_s"], alpha=alpha,
                                min_improvement=min_improvement):
        return "oscillatory_disturbance"
    return pick


def band_dof(n_val: int, Ts: float, f_hp: float | None, f_lp: float | None) -> float:
    """Independent samples that ``n_val`` validation samples hold in the comparison band
    ``[f_hp, f_lp]`` Hz: ``2 · n_val · Ts · (f_lp − f_hp)`` (a band of width ``B`` carries
    ``2B`` independent values per second); ``inf`` without a low-pass.

    Examples
    --------
    >>> round(band_dof(1000, 1.0, 0.001, 0.05), 1)
    98.0
    """
    if f_lp is None:
        return math.inf
    return 2.0 * n_val * Ts * max(f_lp - (f_hp or 0.0), 0.0)


def record_warning(dof: float, reference: float = BAND_DOF) -> str | None:
    """The warning for a record that holds fewer than ``reference`` independent samples
    in the comparison band (:func:`band_dof`), else ``None``.

    Why: at level 2 of the holdout family, with each loop moved to slower speeds alone,
    the faults named fell from 86 % (τ < 30 s, 1 s sampling, 3000 s) to 52 % (τ ≥ 30 s,
    in-band samples 13–59); the same loops recorded three times as long were named 56
    times more and never less (``reports/concealed/slow_loops_named.md``). A verdict of
    ``none`` on such a record says little, and the remedy is the record's length.

    Examples
    --------
    >>> record_warning(400.0) is None
    True
    >>> record_warning(25.0)[:52]
    'the record holds few independent samples in the comp'
    """
    if not dof < reference:
        return None
    return (f"the record holds few independent samples in the comparison band (band_dof "
            f"{dof:.0f}, under {reference:g}: a loop slow for its record), so a fault can "
            "go unseen and a named one is less sure; a record about "
            f"{reference / max(dof, 1e-9):.1f} times as long would hold {reference:g} "
            "(reports/concealed/slow_loops_named.md)")


def scaled_gate(min_improvement: float, dof: float, reference: float = BAND_DOF) -> float:
    """The NRMSE gate for a comparison band holding ``dof`` independent validation
    samples: ``min_improvement`` at ``reference`` or more, ``min_improvement ·
    √(reference/dof)`` below.

    Why: the gate is an effect size measured on the band, and the improvement a
    hypothesis reaches there by chance spreads as ``1/√dof``; a slow loop sampled fast
    leaves few independent samples in a record (a time constant of 120 s over 3000 s at
    1 s: about 13), and healthy loops were called faulty through the gate 7 % of the time
    with it unscaled under 100 in-band samples, against 0 of 336 with 100 or more
    (``reports/concealed/slow_loops.md``; OP held at its limit, named from OP and not
    through the gate, aside). Scaling keeps the
    gate's chance level where it holds on faster loops, at the price of missing small
    effects on slow ones.

    Examples
    --------
    >>> scaled_gate(0.1, 400.0), round(scaled_gate(0.1, 25.0), 3)
    (0.1, 0.2)
    """
    if not dof > 0:
        return min_improvement
    return min_improvement * math.sqrt(max(1.0, reference / dof))


def range_candidates(rows: list[dict[str, Any]], *,
                     alpha_full: float = FULL_DATA_ALPHA) -> list[dict[str, Any]]:
    """The rows of :data:`RANGE_HYPOTHESES` whose full-data test (``p_full``) is below
    ``alpha_full``, whose validation NRMSE is not worse than the nominal's and whose fit
    is not on an end of its search range."""
    return [r for r in rows if r["physics"] in RANGE_HYPOTHESES
            and r.get("p_full") is not None and r["p_full"] < alpha_full
            and r["improvement"] > 0.0 and not r.get("at_bound", False)]


def range_fallback(pick: str, rows: list[dict[str, Any]], *,
                   alpha_full: float = FULL_DATA_ALPHA) -> str:
    """``pick``, or where it is ``none`` the range hypothesis of smallest full-data
    p-value among :func:`range_candidates`.

    Why: a travel limit or a curved installed characteristic shows only while OP is
    beyond the limit or far along the curve, and the alternating block split can leave
    few of those episodes in the validation blocks; the effect there then falls below
    the NRMSE gate though the fit pins the limit or the rangeability (level-2 limits and
    rangeabilities fitted close to the truth and named ``none``). Where the validation
    blocks hold none of them the validation fit is usually worse than the nominal's and
    the test does not name it (``reports/concealed/saturation_evidence.md``). The classic
    prediction-error test on every block (Ljung 1999, ch. 16.4) uses them all, at a level
    that allows for its in-sample part (:data:`FULL_DATA_ALPHA`); the validation blocks
    must still not contradict the fit. Only where nothing else was named, so it never overrides a
    verdict the validation blocks support. Applied against a given model only
    (:func:`.diagnose.diagnose`): without one the nominal was itself identified on every
    block.
    """
    if pick != "none":
        return pick
    cands = range_candidates(rows, alpha_full=alpha_full)
    return min(cands, key=lambda r: r["p_full"])["physics"] if cands else pick


def with_range_fallback(verdict: Verdict, op: np.ndarray, Ts: float, f_hp: float,
                        val: np.ndarray, *,
                        alpha_full: float = FULL_DATA_ALPHA) -> Verdict:
    """``verdict`` with :func:`range_fallback` applied: where it answered ``none``, the
    test is reported under ``tests["full_data_range"]`` (its level, each range
    hypothesis's ``p_full`` and what it named) and, where it names a hypothesis, the
    residual tests are those of that hypothesis; ``verdict`` itself where it named
    physics (the test was not needed)."""
    if verdict.pick != "none":
        return verdict
    pick = range_fallback(verdict.pick, verdict.ranking, alpha_full=alpha_full)
    report = {"alpha": alpha_full, "named": None if pick == verdict.pick else pick,
              "p_full": {r["physics"]: r.get("p_full") for r in verdict.ranking
                         if r["physics"] in RANGE_HYPOTHESES}}
    tests = {**verdict.tests, "full_data_range": report}
    if pick != verdict.pick:  # the residual tests of the hypothesis named, not the nominal's
        kept = {k: v for k, v in tests.items()
                if k not in ("vs_nominal", "whiteness", "independence_from_op")}
        tests = _residual_tests(kept, verdict.ranking, pick, verdict.output_errors,
                                verdict.train, op, Ts, f_hp, val)
    return replace(verdict, pick=pick, tests=tests)


def _bic(row: dict[str, Any]) -> float:
    """A row's BIC (``raw_score``, or the ranking's ``score``: the same up to a constant)."""
    return float(row.get("raw_score", row.get("score", 0.0)))


def _ranking(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    best = min(r["raw_score"] for r in rows)
    keys = ("physics", "improvement", "improvement_kstep", "p_value", "p_one_step",
            "p_k_step", "p_gate", "p_full", "lr_statistic", "df", "nrmse_validation",
            "innovation_variance", "significant", "at_bound", "parameters")
    return sorted(({"score": r["raw_score"] - best, **{k: r[k] for k in keys}} for r in rows),
                  key=lambda r: r["score"])


def _residual_tests(tests: dict[str, Any], rows: list[dict[str, Any]], pick: str,
                    oe: dict[str, np.ndarray], train: np.ndarray | None, op: np.ndarray,
                    Ts: float, f_hp: float, val: np.ndarray, *,
                    model_given: bool = True) -> dict[str, Any]:
    """``tests`` with the named model's ``vs_nominal`` test and Ljung's residual analysis
    (Ljung 1999, §16.6): its output error whitened by a noise model of its own
    (:data:`RESIDUAL_NOISE_FAMILY`, fitted on the training blocks), the innovations'
    whiteness (Ljung–Box) and independence from past OP on the validation blocks."""
    row = next(r for r in rows if r["physics"] == pick)
    u = band_of(model_given)(op, Ts, f_hp)  # pre-whitened by its own AR model in the test
    r = oe[pick]
    fitted_on = r[train] if train is not None and train.size else r
    noise = fit_noise_model(fitted_on, family=RESIDUAL_NOISE_FAMILY)
    e = noise.whiten(r)
    said = {"whitened_by": noise.to_dict()["family"]}
    return {"vs_nominal": {"statistic": row["lr_statistic"], "p_value": row["p_value"],
                           "df": row["df"]},
            **tests,
            "whiteness": {**ljung_box(e[val]), **said},
            "independence_from_op": {**input_independence(e[val], u[val]), **said}}

