"""The routes to a verdict after the likelihood tests' ranking (the end of stage 5,
:func:`.diagnose.answer`).

The ranking (:mod:`.evidence`) names what its tests on the validation blocks support.
Some physics leaves evidence those tests do not see, and a few checks look for it where
the ranking named nothing, each with its own, stated reason: OP held at a limit, read off
OP itself (:func:`name_held_limit`); the loop's gain measured through its set-point moves
(:func:`name_gain_error`); and the line test, which renames an OP-driven pick whose gain
lies at the residual's line alone (:func:`name_line`). :func:`after_comparison` orders the
first two; :func:`floor_answer` holds back what was named where the nominal model already
explains PV within the data's resolution. :func:`decided_by` records which route set the
verdict (``details.decided_by``, :data:`DECISION_ROUTES`);
``reports/concealed/decision_routes.md`` measures how often each was right on sets made by
generators the package shares no code with.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from .evidence import VALVE_HYPOTHESES
from .gain import GainTest
from .result import Diagnosis

__all__ = ["DECISION_ROUTES", "DRIVE_CHECK", "DRIVE_EXEMPT", "RESOLUTION_FLOOR", "after_comparison",
           "decided_by", "drive_answer",
           "floor_answer", "name_gain_error", "name_held_limit", "name_line",
           "pairing_answer", "pairing_test", "valve_family_note"]

#: below this validation NRMSE of the nominal model nothing is named
#: (:func:`floor_answer`)
RESOLUTION_FLOOR = 0.005


def floor_answer(d: Diagnosis, floor: float = RESOLUTION_FLOOR) -> Diagnosis:
    """``none`` in place of a named physics where the nominal model already explains PV
    to within ``floor`` of its spread (validation NRMSE, ``fit.nominal``), in place; what
    was named, and its fit, stay under ``details.resolution_floor``.

    Why: on noise-free recordings with the exact model, the likelihood tests have all the
    power there is and the effect-size gate is relative to the nominal's residual, so a
    physics that changes PV by a ten-thousandth of its spread was named (generator D's
    healthy loops with neither noise nor load: 21 of 48, a median nominal NRMSE of
    0.0037). 0.5 % of PV's spread is below a transmitter's accuracy for a PV that moves
    over a fair part of its span; set a priori, and checked before it was adopted
    (``reports/concealed/resolution_floor.md``): it changed none of the 2112 verdicts of
    the eleven independent sets (noise of 1–10 % of a set-point step: none was below it)
    and took those clean loops' false alarms from 21 to 10 of 48. A saturation named
    because OP is held at a limit (:func:`name_held_limit`) is left alone: its evidence
    is OP itself, and the nominal explains PV there by construction.

    Examples
    --------
    >>> from stictionbench.diagnosis.model import NominalModel
    >>> m = NominalModel(1.0, 10.0, 1.0)
    >>> d = Diagnosis(True, "deadband", {"deadband": 0.1}, {"nominal": 0.001,
    ...               "improved": 0.0008}, [], [], [], m, {"deadband": [0.05, 0.2]})
    >>> floor_answer(d).missing_physics, d.parameters, d.fit["improved"]
    ('none', {}, 0.001)
    >>> d.details["resolution_floor"]["named_before"]
    'deadband'
    """
    nominal = d.fit.get("nominal")
    if d.missing_physics == "none" or nominal is None or not nominal < floor:
        return d
    if d.tests.get("op_held_at_limit", {}).get("named"):
        # read off OP itself, not a fit's improvement: a clamped OP drives the plant as
        # recorded, so the nominal explains PV there by construction (name_held_limit)
        return d
    return _hold_back(d, "resolution_floor", {
        "floor": float(floor), "nominal_nrmse": float(nominal),
        "reason": (f"the nominal model explains PV to within {nominal:.2g} of its spread "
                   f"on the validation blocks (below {floor:g}): nothing is named")})


def _hold_back(d: Diagnosis, key: str, info: dict[str, Any]) -> Diagnosis:
    """``none`` in place of ``d``'s answer, in place: what was named, its parameters and
    improved fit go to ``details[key]`` beside ``info``; the fit becomes the nominal's."""
    nominal = d.fit.get("nominal")
    d.details[key] = {**{k: v for k, v in info.items() if k != "reason"},
                      "named_before": d.missing_physics, "parameters_before": d.parameters,
                      "improved_before": d.fit.get("improved"), "reason": info["reason"]}
    d.missing_physics, d.parameters, d.uncertainty = "none", {}, {}
    if "rival" in d.tests:
        d.tests["rival"] = {"method": d.tests["rival"].get("method", "vuong"), "rival": None,
                            "reason": f"the answer is the nominal model ({key})"}
    fit = {**d.fit, "improved": nominal}
    if isinstance(fit.get("innovation_variance"), dict):
        iv = fit["innovation_variance"]
        fit["innovation_variance"] = {**iv, "improved": iv.get("nominal")}
    d.fit = fit
    d.details["decided_by"] = decided_by(d)
    return d


def valve_family_note(d: Diagnosis) -> str | None:
    """Why a dead band is named whose own fit does not pass its test, else None.

    Stiction and the dead band are one nested family (:func:`.evidence.select`): once
    either passes its test against the nominal model, the slip-jump test names the
    member, and an unresolved ``J`` names the dead band. When the dead band's own row
    did not pass (its validation NRMSE need not even improve) while the stiction fit
    did, the answer stands on the stiction fit's evidence, and the summary's
    "validation NRMSE a -> b" (the named fit's) can show a worse fit. The note says so,
    with both fits and the slip-jump p-value, so the line does not read as a
    contradiction.

    Examples
    --------
    >>> from stictionbench.diagnosis.model import NominalModel
    >>> rows = [{"physics": "deadband", "significant": False, "nrmse_validation": 0.75},
    ...         {"physics": "stiction", "significant": True, "nrmse_validation": 0.59}]
    >>> d = Diagnosis(True, "deadband", {}, {"nominal": 0.67, "improved": 0.75}, [], [],
    ...               rows, NominalModel(1.0, 10.0, 1.0), {},
    ...               details={"decided_by": "likelihood_tests"},
    ...               tests={"slip_jump_zero": {"p_value": 0.2}})
    >>> valve_family_note(d)[:44]
    'a sticky valve is named on the stiction fit:'
    >>> d.ranking[0]["significant"] = True
    >>> valve_family_note(d) is None
    True
    """
    if d.missing_physics != "deadband" or \
            d.details.get("decided_by") not in ("likelihood_tests", "closed_loop_cycle"):
        return None
    rows = {r.get("physics"): r for r in d.ranking or []}
    db, st = rows.get("deadband"), rows.get("stiction")
    if db is None or st is None or db.get("significant") or not st.get("significant"):
        return None
    p = (d.tests.get("slip_jump_zero") or {}).get("p_value")
    why = ("its slip jump J is not resolved" + (f" (p = {p:.2g})" if p is not None else "")
           + " or is small against S")
    return (f"a sticky valve is named on the stiction fit: it beats the nominal model "
            f"(validation NRMSE {d.fit.get('nominal', float('nan')):.3f} -> "
            f"{st.get('nrmse_validation', float('nan')):.3f}), but {why}, so the "
            f"family's simpler member, the dead band, is named; the dead band's own fit "
            f"does not pass its test (validation NRMSE "
            f"{db.get('nrmse_validation', float('nan')):.3f})")


def pairing_test(rec: Any, alpha: float, dead_time: float | None = None,
                 time_constant: float | None = None) -> dict[str, Any]:
    """``tests.op_pv_dependence``: Haugh's test that the recording's OP and PV are
    independent (:func:`.noise.series_independence`), ``independent`` when it cannot
    reject that at ``alpha``; ``warning`` then says what it means.

    OP reaches PV a dead time later and over a few time constants, so the lags must
    reach that far: with the loop's time scales known (a model given, or the one
    identified), the test is made at the fixed window of
    :data:`~.noise.INDEPENDENCE_LAGS` samples, at twice, four times … that window and at
    ``(θ + 2τ)/Ts`` samples (at most a tenth of the record), and its p-value is the
    smallest one, Bonferroni-corrected (``windows`` lists them): a window far wider than
    the lags that carry the dependence dilutes it over its χ² degrees of freedom. A
    first version used the fixed window alone and called OP and PV independent on the
    paper's own loops at 0.1 s sampling (dead time 100 samples): ``p = 0.98`` for the
    well-tuned linear loop, 1 for the sticky one, against ``p < 1e-18`` with the lags
    reaching ``θ + 2τ``.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=3000)
    >>> y = np.r_[np.zeros(120), u[:-120]] + 0.5 * rng.normal(size=3000)  # 120-sample delay
    >>> rec = SimpleNamespace(PV=y, OP=u, Ts=1.0)
    >>> pairing_test(rec, 0.05)["independent"]
    True
    >>> t = pairing_test(rec, 0.05, dead_time=120.0, time_constant=5.0)
    >>> t["independent"], t["windows"], t["peak_lag"]
    (False, [50, 100, 130], 120)
    """
    import math

    from .noise import INDEPENDENCE_LAGS, series_independence

    windows = [INDEPENDENCE_LAGS]
    if dead_time is not None and time_constant is not None:
        reach = int(math.ceil((dead_time + 2.0 * time_constant) / float(rec.Ts)))
        reach = min(reach, max(INDEPENDENCE_LAGS, len(rec.PV) // 10))
        while 2 * windows[-1] < reach:
            windows.append(2 * windows[-1])
        if reach > windows[-1]:
            windows.append(reach)
    runs = [series_independence(rec.PV, rec.OP, lags=m) for m in windows]
    t = dict(min(runs, key=lambda r: r["p_value"]))
    t["p_value"] = float(min(1.0, len(runs) * t["p_value"]))
    t["windows"] = [int(r["lags"]) for r in runs]
    t["independent"] = bool(t["p_value"] >= alpha)
    # one direction: the lags at which OP leads PV (the process's), same windows
    lead = min(r["p_u_leads"] for r in runs)
    t["p_op_leads"] = float(min(1.0, len(runs) * lead))
    t["op_drives_pv"] = bool(t["p_op_leads"] < alpha)
    for key in ("p_u_leads", "p_y_leads"):
        t.pop(key, None)
    if t["independent"]:
        reach = max(t["windows"])
        t["warning"] = (f"OP and PV are independent by Haugh's test (p = {t['p_value']:.2g} "
                        f"at lags up to ±{reach} samples): this OP does not drive this "
                        "PV and no controller answers it: a tag of another loop, a PV "
                        "that does not measure (a frozen transmitter), or a controller "
                        "in manual with the process at rest; check the tags")
    return t


def pairing_answer(d: Diagnosis, alpha: float) -> Diagnosis:
    """``none`` in place of a named physics where the recording's OP and PV are
    independent (``tests.op_pv_dependence``, :func:`pairing_test`), in place; what was
    named stays under ``details.op_pv_independent``.

    Why: every closed loop makes OP and PV dependent (the process one way, the
    controller the other), and every hypothesis explains PV from OP. Where the data
    cannot reject their independence, the model identified from them (or the one given)
    is not this PV's, and a physics named by its fit is named from noise.

    Examples
    --------
    >>> from stictionbench.diagnosis.model import NominalModel
    >>> d = Diagnosis(True, "deadband", {"deadband": 0.1}, {"nominal": 0.9,
    ...               "improved": 0.7}, [], [], [], NominalModel(1.0, 10.0, 1.0), {},
    ...               tests={"op_pv_dependence": {"p_value": 0.4, "independent": True}})
    >>> pairing_answer(d, 0.05).missing_physics, d.details["decided_by"]
    ('none', 'op_pv_independent')
    """
    t = d.tests.get("op_pv_dependence") or {}
    return _pairing_hold(d, "op_pv_independent", bool(t.get("independent")), (), {
        "p_value": float(t.get("p_value", 1.0)), "alpha": float(alpha),
        "reason": f"OP and PV are independent by Haugh's test (p = "
                  f"{t.get('p_value', 1.0):.2g}, not below {alpha:g}): nothing explains "
                  "PV from OP, so nothing is named"})


def _pairing_hold(d: Diagnosis, key: str, fires: bool, exempt: tuple[str, ...],
                  info: dict[str, Any]) -> Diagnosis:
    """The pairing routes' shared rule: where the test ``fires``, ``none`` in place of a
    named physics (:func:`_hold_back` under ``details[key]``), except a physics in
    ``exempt`` and a saturation read off OP held at a limit (its evidence is OP itself,
    as :func:`floor_answer`)."""
    if not fires or d.missing_physics == "none" or d.missing_physics in exempt:
        return d
    if d.tests.get("op_held_at_limit", {}).get("named"):
        return d
    return _hold_back(d, key, info)


#: whether :func:`drive_answer` is applied by default (``reports/diagnose/op_drives_pv.md``:
#: the criterion fixed before its run, and its outcome)
DRIVE_CHECK = False
#: verdicts whose evidence is not OP's effect on PV, kept where OP does not drive PV: a line
#: in PV itself (an external oscillation needs no path from OP); a limit read off OP held
#: there is kept by the check's own rule (the loop is open while OP is held)
DRIVE_EXEMPT = ("oscillatory_disturbance",)


def drive_answer(d: Diagnosis, alpha: float) -> Diagnosis:
    """``none`` in place of a physics whose evidence is OP's effect on PV where the
    recording's OP does not drive its PV (``tests.op_pv_dependence.op_drives_pv``: the
    lags at which OP leads PV show nothing, :func:`pairing_test`), in place; what was
    named stays under ``details.op_not_driving_pv``.

    Why: a controller answers PV whether or not its valve moves, so OP and PV stay
    dependent (the pairing test rejects independence) in a loop whose valve is at rest,
    and every hypothesis then explains PV from an OP that does not reach it: the
    identified process fits the transmitter's noise (``reports/diagnose/op_drives_pv.md``).

    Why it is off by default: at a constant set point nothing but the controller moves
    OP, OP is then a function of PV's past, and OP's past adds nothing to PV's prediction
    even where the valve moves PV (feedback between time series; Caines & Chan, *IEEE
    TAC* 20 (1975) 498). A healthy regulatory loop fires as a valve at rest does
    (``reports/diagnose/drive_check_regulation.md``).

    Examples
    --------
    >>> from stictionbench.diagnosis.model import NominalModel
    >>> d = Diagnosis(True, "dead_time", {"dead_time": 53.0}, {"nominal": 0.9,
    ...               "improved": 0.7}, [], [], [], NominalModel(1.0, 10.0, 1.0), {},
    ...               tests={"op_pv_dependence": {"p_op_leads": 0.5, "op_drives_pv": False}})
    >>> drive_answer(d, 0.05).missing_physics, d.details["decided_by"]
    ('none', 'op_not_driving_pv')
    """
    t = d.tests.get("op_pv_dependence") or {}
    fires = not t.get("op_drives_pv", True)
    return _pairing_hold(d, "op_not_driving_pv", fires, DRIVE_EXEMPT, {
        "p_value": float(t.get("p_op_leads", 1.0)), "alpha": float(alpha),
        "reason": f"OP does not lead PV at any lag (one direction of Haugh's test, "
                  f"p = {t.get('p_op_leads', 1.0):.2g}, not below {alpha:g}): the controller "
                  "answers PV but nothing OP does reaches it (a valve at rest, a "
                  "controller whose output goes elsewhere), so nothing acting through "
                  "OP is named"})


#: the route by which :func:`answer` (or :func:`floor_answer`) reached the verdict,
#: ``details.decided_by``, each with what it means (the summary's "Decided by" line)
DECISION_ROUTES = {
    "likelihood_tests": "the likelihood-ratio tests against the nominal model on the "
                        "validation blocks, the NRMSE gate and the hypotheses' ranking",
    "slow_line": "the second look for a line slower than the main band (the main band "
                 "named nothing)",
    "full_data_range": "the full-data likelihood-ratio test of a travel limit or a curved "
                       "characteristic (nothing passed on the validation blocks alone)",
    "line_confined": "the line test: the named fit gains at the residual's line alone, "
                     "which an external oscillation explains",
    "op_held_at_limit": "OP held at a limit, read off OP itself (the comparison named "
                        "nothing)",
    "setpoint_gain": "the set-point gain test: the loop's gain measured through its "
                     "set-point moves differs from the model's (the comparison named "
                     "nothing; the hypotheses' ranking does not choose it)",
    "detection": "detection, then quantification (no model given): the published "
                 "detectors' combined verdict found a sticky valve and the stiction fit's "
                 "slip jump has an interval that excludes 0",
    "closed_loop_cycle": "the closed-loop cycle check: the identified valve, closed with "
                         "the loop's PI, reproduces the recorded oscillation by itself, so "
                         "the significant valve hypothesis is named over a significant "
                         "rival of lower score",
    "resolution_floor": "the resolution floor: the nominal model already explains PV "
                        "within it, so what the tests named is held back",
    "op_not_driving_pv": "the drive check: OP leads PV at no lag (one direction of "
                         "Haugh's test), so nothing acting through OP is named",
    "op_pv_independent": "the pairing check: OP and PV are independent by Haugh's test, "
                         "so what the tests named from OP is held back",
}


def decided_by(d: Diagnosis) -> str:
    """Which check of :func:`answer` set the verdict (a key of :data:`DECISION_ROUTES`),
    read from the flags each one leaves: the last that named something, in the order
    :func:`answer` runs them (``likelihood_tests`` when none did, the verdict ``none``
    included).

    Examples
    --------
    >>> from stictionbench.diagnosis.model import NominalModel
    >>> d = Diagnosis(True, "valve_characteristic", {}, {}, [], [], [],
    ...               NominalModel(1.0, 10.0, 1.0), {},
    ...               tests={"setpoint_gain": {"named": True}})
    >>> decided_by(d)
    'setpoint_gain'
    >>> d.tests = {"setpoint_gain": {"named": False}}
    >>> decided_by(d)
    'likelihood_tests'
    """
    if d.details.get("op_pv_independent"):
        return "op_pv_independent"
    if d.details.get("op_not_driving_pv"):
        return "op_not_driving_pv"
    if d.details.get("resolution_floor"):
        return "resolution_floor"
    if d.tests.get("detection", {}).get("named"):
        return "detection"
    for key in ("setpoint_gain", "op_held_at_limit", "line_confined", "full_data_range"):
        if d.tests.get(key, {}).get("named"):
            return key
    if (d.details.get("slow_line") or {}).get("named"):
        return "slow_line"
    if (d.tests.get("closed_loop_cycle") or {}).get("reproduced") and \
            d.missing_physics in VALVE_HYPOTHESES:
        sig = [r for r in d.ranking if r.get("significant")]
        if sig and min(sig, key=lambda r: r["score"])["physics"] not in VALVE_HYPOTHESES:
            return "closed_loop_cycle"
    return "likelihood_tests"


def after_comparison(pick: str, op_held: bool, gain_flagged: bool) -> str:
    """The verdict after the checks that name physics where the comparison named nothing
    (``pick == "none"``): ``saturation`` where OP is held at a limit
    (:func:`name_held_limit`), else ``valve_characteristic`` where the set-point gain test
    flagged a gain error (:func:`name_gain_error`); otherwise ``pick``. The one place that
    orders them, for :func:`diagnose` and for re-decisions from stored flags
    (``experiments/concealed.py``).

    Examples
    --------
    >>> after_comparison("none", True, True), after_comparison("none", False, True)
    ('saturation', 'valve_characteristic')
    >>> after_comparison("stiction", True, True)
    'stiction'
    """
    if pick != "none":
        return pick
    if op_held:
        return "saturation"
    return "valve_characteristic" if gain_flagged else pick


def name_line(d: Diagnosis, test: dict[str, Any]) -> Diagnosis:
    """Name ``oscillatory_disturbance`` in place of a dead time or sensor lag whose
    improvement lies at the residual's line (:func:`.line.line_confinement`), in place;
    the test is reported under ``tests["line_confined"]`` either way.

    The answer's parameters and fit are the oscillatory disturbance's own where it was
    fitted at the line (its period within the line's band), else the line's period alone
    with no improvement claimed: a sinusoid of fixed phase need not fit a line whose
    period wanders, which is how the OP-driven fit came to explain it."""
    d.tests["line_confined"] = test
    if not test["named"]:
        return d
    name, was = "oscillatory_disturbance", d.missing_physics
    period = float(test["line_period_s"])
    ft = d.fits.get(name)
    own = ft is not None and abs(ft.params.get("period", 0.0) / period - 1.0) <= test["band"]
    if own:
        d.parameters, d.uncertainty = dict(ft.params), dict(ft.intervals)
        d.fit = {**d.fit, "improved": ft.nrmse_val}
    else:
        # its fit is the nominal one, the line's period read off the residual
        base = d.fits["none"]
        d.fits[name] = replace(base, name=name, params={"period": period}, intervals={},
                               p=np.array([period]))
        d.parameters, d.uncertainty = {"period": period}, {}
        d.fit = {**d.fit, "improved": base.nrmse_val}
    d.missing_physics, d.mismatch_detected = name, True
    d.details["line_confined"] = (
        f"the mismatch lies at one line (period {period:.4g} s): {test['share']:.0%} of "
        f"what the {was.replace('_', ' ')} fit gains is within ±{test['band']:.0%} of "
        "that line's frequency. Physics acting on OP changes the prediction wherever OP "
        "has power; a gain at one line alone is the closed loop's echo of an external "
        "oscillation in OP, which a shifted or reshaped replay of OP follows"
        + ("" if own else "; a sinusoid of fixed phase was not fitted there (a wandering "
           "period), so no improvement is claimed"))
    return d


def name_held_limit(d: Diagnosis, held: dict[str, Any], name: bool) -> Diagnosis:
    """Name ``saturation`` from OP held at a limit (:func:`.op_limit.held_at_limit`) when
    ``name`` (:func:`after_comparison` chose it: the comparison named nothing), in place;
    the check is reported under ``tests["op_held_at_limit"]`` either way, and a hold
    beside another verdict draws ``details["limit_warning"]``.

    A recorded OP clamped at its limit drives the plant exactly as recorded, so the
    nominal model's response to it shows no mismatch (:mod:`.op_limit`): the saturation
    hypothesis at the held limit predicts what the nominal model predicts, and its fit is
    that one, the limit read off the data (its interval a point)."""
    d.tests["op_held_at_limit"] = {**held, "named": False}
    if not held["held"]:
        return d
    what = (f"OP held at its {held['side']} limit ({held['limit']:.4g}) for "
            f"{held['fraction']:.1%} of the record ({held['runs']} holds, the longest "
            f"{held['longest_run']} samples): the loop is open while it stays there")
    if not name:
        d.details["limit_warning"] = what
        return d
    key = "op_high" if held["side"] == "high" else "op_low"
    v = float(held["limit"])
    base = d.fits["none"]
    d.fits["saturation"] = replace(
        base, name="saturation", params={key: v}, intervals={key: [v, v]},
        p=np.array([-np.inf, v]) if key == "op_high" else np.array([v, np.inf]))
    d.missing_physics, d.parameters, d.uncertainty = "saturation", {key: v}, {key: [v, v]}
    d.mismatch_detected = True
    d.fit = {**d.fit, "improved": base.nrmse_val}
    d.tests["op_held_at_limit"]["named"] = True
    d.details["op_held_at_limit"] = what
    return d


def name_gain_error(d: Diagnosis, test: GainTest, name: bool) -> Diagnosis:
    """Name ``valve_characteristic`` from the gain measured through the set point's moves
    (:func:`.gain.setpoint_gain`) when ``name`` (:func:`after_comparison` chose it:
    nothing else was named and the gain differs from the model's), in place; the test is
    reported under ``tests["setpoint_gain"]`` either way.

    Every hypothesis fits the gain freely, so an installed characteristic whose slope at
    the operating point is not the model's, over an OP range too narrow for its curve to
    show, is a gain error the comparison cannot see (:mod:`.gain`). The answer's
    parameter is that slope as a ratio, ``gain_ratio`` (measured over given, with its
    interval); its fit is the nominal model with the given gain (``fit.nominal``) and
    with the measured one (``fit.improved``), validation NRMSE both."""
    d.tests["setpoint_gain"] = {**test.to_dict(), "named": False}
    if not name:
        return d
    d.missing_physics, d.mismatch_detected = "valve_characteristic", True
    if test.y is not None and test.pred is not None:
        d.fits["valve_characteristic"] = replace(
            d.fits["none"], name="valve_characteristic", pred=test.pred,
            resid=test.y - test.pred, params={"gain_ratio": test.ratio},
            p=np.array([test.ratio]))
    d.parameters = {"gain_ratio": test.ratio}
    d.uncertainty = {"gain_ratio": [float(v) for v in test.interval]}
    d.fit = {**d.fit, "nominal": test.nrmse_given, "improved": test.nrmse_measured}
    d.tests["setpoint_gain"]["named"] = True
    d.details["setpoint_gain"] = (
        f"the loop's gain measured through its set-point moves is {test.ratio:.3g} times "
        f"the model's ({test.interval[0]:.3g}–{test.interval[1]:.3g}, p = "
        f"{test.p_value:.2g}): a valve slope at the operating point the model does not have")
    return d
