"""Rendering a :class:`~.diagnose.Diagnosis`: figures (PNG) and a one-minute Markdown
summary for a plant engineer."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io import write_text
from ..reports.figures import new_figure, save_png
from .diagnose import WARNING_KEYS
from .evidence import ALPHA
from .hypotheses import HYPOTHESES, Context
from .result import Diagnosis
from .routes import DECISION_ROUTES

PLAIN = {
    "none": "no physics in the vocabulary improves significantly on the nominal model",
    "stiction": "a sticky valve: it holds until the controller output has moved by S, "
                "then jumps by J",
    "deadband": "a valve deadband/backlash: the valve follows the controller output only "
                "after it has reversed by the deadband",
    "sensor_lag": "an extra lag in the measurement (transmitter damping or a slow sensor)",
    "dead_time": "a different transport delay than the model assumes",
    "valve_characteristic": "a non-linear (equal-percentage) installed valve "
                            "characteristic: the loop gain changes with valve opening",
    "saturation": "valve travel limits the controller does not know about",
    "oscillatory_disturbance": "an external oscillating disturbance entering the process",
}


def _shade(ax, windows):
    for i, (a, b) in enumerate(windows):
        ax.axvspan(a, b, color="orange", alpha=0.2, label="mismatch window" if i == 0 else None)


#: the time axis: in ``t``'s own unit (seconds for date-times), which may be any
TIME_LABEL = "time (t's unit: s for date-times)"


def _op_unit(d: Diagnosis) -> str:
    """OP's unit on the figures' axes: per cent of travel, a fraction of it, the range
    the user gave, or OP's own units when none is known (mean-removed, engineering)."""
    span = d.details.get("op_range")
    if span is None:
        return "own units"
    lo, hi = span
    if (lo, hi) == (0.0, 100.0):
        return "%"
    if (lo, hi) == (0.0, 1.0):
        return "fraction of travel"
    return f"units: {lo:g} to {hi:g} = 0 to 100 %"


def write_report(d: Diagnosis, out_dir: str | Path) -> list[Path]:
    """Write figures and ``summary.md`` for a diagnosis into ``out_dir``."""
    out = Path(out_dir)
    rec = d.rec
    assert rec is not None
    t = rec.t
    nom = d.fits["none"]
    best = d.fits[d.missing_physics]
    y_hp = nom.resid + nom.pred  # the high-passed PV
    nom_pred = nom.pred
    if d.tests.get("setpoint_gain", {}).get("named"):
        # the nominal model as given (its gain, not the fitted one: :mod:`.gain`)
        nom_pred = best.pred / d.parameters["gain_ratio"]
    nom_resid = y_hp - nom_pred
    paths = []
    # 1. recording vs nominal vs improved (high-passed: what the fit compares)
    fig, ax = new_figure(figsize=(9, 4))
    ax.plot(t, y_hp, color="k", lw=0.8, label="recorded PV (slow load removed)")
    ax.plot(t, nom_pred, lw=1, label="nominal model")
    if d.missing_physics != "none":
        ax.plot(t, best.pred, lw=1, label=f"with {d.missing_physics}")
    for i, (a, b) in enumerate(d.val_blocks):
        ax.axvspan(a, b, color="grey", alpha=0.12, label="validation" if i == 0 else None)
    ax.set(xlabel=TIME_LABEL, ylabel="PV (deviation)", title="Recording vs simulations")
    ax.legend(loc="lower left")
    paths.append(save_png(fig, out / "replay.png"))
    # 2. residual before/after with windows
    fig, ax = new_figure(figsize=(9, 4))
    _shade(ax, d.mismatch_windows)
    ax.plot(t, nom_resid, lw=0.8, label="residual, nominal")
    if d.missing_physics != "none":
        ax.plot(t, best.resid, lw=0.8, label=f"residual, with {d.missing_physics}")
    ax.set(xlabel=TIME_LABEL, ylabel="PV − model", title="Residual before and after")
    ax.legend(loc="lower left")
    paths.append(save_png(fig, out / "residual.png"))
    # 3. residual spectrum
    sp = d.spectrum
    fig, ax = new_figure()
    if "f" in sp:
        ax.semilogy(sp["f"][1:], sp["psd"][1:], label="nominal residual PSD")
        ax.axhline(sp["floor"], color="k", ls=":", label="white-noise floor")
        if d.mismatch_band_hz:
            ax.axvspan(*d.mismatch_band_hz, color="orange", alpha=0.2, label="mismatch band")
    ax.set(xlabel="frequency (Hz)", ylabel="PSD (PV units² per Hz)", title="Where in frequency")
    ax.legend()
    paths.append(save_png(fig, out / "spectrum.png"))
    # 4. phase plots: PV–OP and the estimated MV–OP
    fig, axs = new_figure(1, 2, figsize=(10, 4))
    axs[0].plot(rec.OP, rec.PV, lw=0.6)
    op_unit = _op_unit(d)
    axs[0].set(xlabel=f"OP ({op_unit})", ylabel="PV", title="PV vs OP (recorded)")
    if d.missing_physics in ("stiction", "deadband", "saturation", "valve_characteristic"):
        mv = estimated_mv(d)
        axs[1].plot(rec.OP, mv, lw=0.8)
        axs[1].set(title=f"estimated valve position vs OP ({d.missing_physics})")
    else:
        axs[1].plot(rec.OP, rec.OP, lw=0.8)
        axs[1].set(title="valve position vs OP (linear valve assumed)")
    axs[1].set(xlabel=f"OP ({op_unit})", ylabel=f"estimated MV ({op_unit})")
    paths.append(save_png(fig, out / "phase.png"))
    write_text(out / "summary.md", summary_markdown(d))
    paths.append(out / "summary.md")
    return paths


def estimated_mv(d: Diagnosis) -> np.ndarray:
    """Valve position implied by the chosen hypothesis (OP for non-valve ones); for a
    gain measured through the set point (:mod:`.gain`), OP scaled about its mean by the
    gain ratio: the valve's slope at the operating point."""
    rec = d.rec
    assert rec is not None
    if d.tests.get("setpoint_gain", {}).get("named"):
        op = np.asarray(rec.OP, float)
        return float(op.mean()) + d.parameters["gain_ratio"] * (op - float(op.mean()))
    ctx = Context(rec.t, np.asarray(rec.OP, float), rec.PV, rec.Ts, d.model.time_constant,
                  d.model.dead_time,
                  op_range=tuple(d.details.get("op_range") or (0.0, 100.0)))
    return HYPOTHESES[d.missing_physics].valve_output(ctx, d.fits[d.missing_physics].p)


def _slow_line_lines(d: Diagnosis) -> list[str]:
    """The second look for a slow line (:func:`.diagnose.second_look`), when it ran."""
    look = d.details.get("slow_line")
    if not look:
        return []
    r = look["oscillatory_disturbance"]
    said = "named it" if look["named"] else "named nothing"
    return [f"- Second look for a slow line (the main band, high-pass corner period "
            f"{look['corner_period_s']:.0f} s, named nothing): with the high-pass at "
            f"{look['highpass_hz']:.3g} Hz a line of period "
            f"{r['parameters'].get('period', float('nan')):.0f} s improves the validation "
            f"NRMSE by {r['improvement']:.0%} (p = {r['p_value']:.2g}); the look {said}"
            + (" (the table below is the main band's)." if look["named"] else ".")]


def _range_lines(d: Diagnosis) -> list[str]:
    """The full-data test of the range hypotheses (:func:`.evidence.range_fallback`),
    when it named one."""
    t = d.tests.get("full_data_range") or {}
    if not t.get("named"):
        return []
    return [f"- Named by the full-data test: no hypothesis passed on the validation blocks "
            f"alone; {t['named']}'s evidence sits where OP went (a limit, the far end of "
            f"the curve), episodes the block split can leave scarce in the validation blocks, "
            f"and "
            f"its likelihood ratio on every block gives p = {t['p_full'][t['named']]:.2g} "
            f"(level {t['alpha']:.0e}, allowing for the in-sample part); the validation "
            f"blocks do not contradict it."]


def _line_lines(d: Diagnosis) -> list[str]:
    """The line test (:mod:`.line`), when it named the line."""
    return [f"- {d.details['line_confined']}."] if d.details.get("line_confined") else []


def _decided_lines(d: Diagnosis) -> list[str]:
    """Which check set the verdict (``details.decided_by``), and the set-point gain
    test's own sentence when it named the verdict."""
    route = d.details.get("decided_by")
    if route not in DECISION_ROUTES:
        return []
    out = [f"- Decided by {DECISION_ROUTES[route]}."]
    if route == "setpoint_gain" and d.details.get("setpoint_gain"):
        out.append(f"- Named by the set-point gain test: {d.details['setpoint_gain']}.")
    return out


def _chosen_mark(d: Diagnosis, physics: str) -> str:
    """The ranking's "chosen" cell: ``yes`` where the ranking chose the verdict, the
    deciding check's name where another check did."""
    if physics != d.missing_physics:
        return ""
    route = d.details.get("decided_by", "likelihood_tests")
    return "yes" if route == "likelihood_tests" else f"yes ({route.replace('_', ' ')})"


def _held_lines(d: Diagnosis) -> list[str]:
    """The OP-held-at-a-limit check (:func:`.op_limit.held_at_limit`), when OP was held."""
    t = d.tests.get("op_held_at_limit") or {}
    if not t.get("held"):
        return []
    said = ("named saturation: the recorded OP is the clamped one, so the nominal model "
            "driven by it shows no mismatch, and the limit is read off OP itself"
            if t["named"] else f"reported beside the verdict ({d.missing_physics})")
    return [f"- OP held at its {t['side']} limit ({t['limit']:.4g}) for "
            f"{t['fraction']:.1%} of the record ({t['runs']} holds of at least "
            f"{t['min_run']} samples, the longest {t['longest_run']}): {said}."]


def _rival_lines(d: Diagnosis) -> list[str]:
    """The answer against its closest rival (:func:`.rival.rival_test`), when it had one."""
    t = d.tests.get("rival") or {}
    if not t.get("rival"):
        return []
    verdict = ("the record tells them apart" if t["distinguishable"] else
               "the record fits both about alike: read the answer as one of the two")
    return [f"- Closest rival: {t['rival']}, which also passed every gate (Vuong's test of "
            f"{d.missing_physics} against it: p = {t['p_value']:.2g}): {verdict}."]


def _gate_lines(d: Diagnosis) -> list[str]:
    """Why a valve hypothesis that beats the nominal model was not credited (model-free:
    it must also beat the linear loop re-identified under the same criterion)."""
    h = d.details.get("hammerstein") or {}
    gated = [r["physics"] for r in d.ranking if r.get("p_gate") is not None]
    if not gated or not h:
        return []
    if not h.get("process_consistent", True):
        why = ("not credited: the process fitted with the valve contradicts the linear "
               "loop's (opposite gain sign, or its τ on the search's lower bound, 0.2 "
               "sample times)")
    else:
        why = (f"p = {h['tests']['valve_vs_linear']['p_value']:.2g} against the linear "
               "loop re-identified under the same criterion")
    return [f"- Valve hypotheses ({', '.join(gated)}): the p-value is the larger of the "
            f"test against the nominal model and the valve's own identification test; "
            f"{why}."]


#: the effects of :mod:`.detectability` in words, with their units' suffix
DETECTABLE_WORDS = {"dead_time_longer": ("dead time longer by", " s"),
                    "dead_time_shorter": ("dead time shorter by", " s"),
                    "sensor_lag": ("sensor lag", " s"), "deadband": ("dead band", ""),
                    "stiction_S": ("stiction S (J = S/2)", "")}


def _detectable_lines(d: Diagnosis) -> list[str]:
    """The smallest effects the record's tests would have seen (:mod:`.detectability`)."""
    m = d.details.get("minimum_detectable")
    if not m:
        return []
    parts = []
    for key, e in m["effects"].items():
        what, unit = DETECTABLE_WORDS[key]
        size = (f"{e['minimum']:.3g}{unit}" if e["minimum"] is not None
                else f"none up to {e['searched_up_to']:.3g}{unit}")
        if "from_dead_time_s" in e:
            size += f" from the {e['from_dead_time_s']:.3g} s the record shows"
        parts.append(f"{what} {size} ({' and '.join(e['limited_by'])})")
    return [f"- Smallest effects this record's tests would have seen (power "
            f"{m['power']:.0%} at alpha {m['alpha']:g}; OP units for valves; in brackets "
            f"what a smaller one fails): " + "; ".join(parts) + "."]


def _residual_lines(d: Diagnosis) -> list[str]:
    """Ljung's residual analysis of the chosen model, in words."""
    w, u = d.tests.get("whiteness"), d.tests.get("independence_from_op")
    if not w or not u:
        return []
    left = [what for what, t in (("not white", w), ("correlated with past OP", u))
            if t["p_value"] < ALPHA]
    which = "nominal" if d.missing_physics == "none" else d.missing_physics
    said = ""
    if left:
        said = (f"; its innovations are {' and '.join(left)}, so something the vocabulary "
                "does not hold (or a noise model too simple) is left unexplained")
        # the PI faster than the record as the diagnosis judged it (the controller-rate
        # warning), or its period not given
        pc = d.model.controller_period
        if u["p_value"] < ALPHA and (pc is None or d.details.get("controller_rate_warning")):
            said += (" — or only a PI faster than the record"
                     + (" (its period is not given)" if pc is None else "")
                     + ": fed the OP snapshots, even the exact model leaves a residual "
                     "that follows OP's moves between samples "
                     "(reports/diagnose/residual_tests_calibration.md)")
    return [f"- Residual analysis of the {which} model (validation blocks, whitened by "
            f"its own {w.get('whitened_by', 'AR')} noise model): whiteness p = "
            f"{w['p_value']:.2g}, independence from past OP p = {u['p_value']:.2g}"
            + said + "."]


def summary_markdown(d: Diagnosis) -> str:
    m = d.model
    lines = [
        "# Diagnosis summary",
        "",
        f"**Verdict: {d.missing_physics}** — {PLAIN[d.missing_physics]}.",
        "",
    ]
    if d.parameters:
        ps = ", ".join(f"{k} = {v:.3g}" + (f" (95 % interval {d.uncertainty[k][0]:.3g}–"
                                            f"{d.uncertainty[k][1]:.3g})"
                                            if k in d.uncertainty else "")
                       for k, v in d.parameters.items())
        lines += [f"- Fitted: {ps}.", ""]
    if d.details.get("valve_opening") == "against_op":
        lines += ["- The valve opens against OP (opening = 100 % − OP: an air-to-close "
                  "valve with its signal recorded), or, with the gain's sign, a "
                  "characteristic concave in OP (a linear valve with little pressure-drop "
                  "authority).", ""]
    f = d.fit
    imp = 1 - f["improved"] / f["nominal"] if f["nominal"] else 0.0
    lines += [
        f"- Fit on data the model did not see (validation blocks, shaded grey): NRMSE "
        f"{f['nominal']:.3f} with the nominal model, {f['improved']:.3f} with "
        f"{d.missing_physics} ({imp:.0%} better).",
        f"- Mismatch detected: {'yes' if d.mismatch_detected else 'no'} (residual variance "
        f"{d.details['residual_to_noise_variance']:.1f}× the noise floor).",
        f"- When: {len(d.mismatch_windows)} window(s)"
        + (": " + ", ".join(f"{a:.0f}–{b:.0f} s" for a, b in d.mismatch_windows[:6])
           if d.mismatch_windows else "") + ".",
        "- Which frequencies: "
        + (f"{d.mismatch_band_hz[0]:.4g}–{d.mismatch_band_hz[1]:.4g} Hz (periods "
           f"{1 / max(d.mismatch_band_hz[1], 1e-12):.0f}–"
           f"{1 / max(d.mismatch_band_hz[0], 1e-12):.0f} s"
           + (" or longer: the excess reaches the slowest period the spectrum's segments "
              "resolve" if d.details.get("mismatch_band_open_below") else "") + ")"
           if d.mismatch_band_hz else "none above the noise floor") + ".",
        f"- Nominal model ({m.source}): K = {m.gain:.3g}, τ = {m.time_constant:.3g} s, "
        f"θ = {m.dead_time:.3g} s" + (f", PI Kc = {m.kc:.3g}, Ti = {m.ti:.3g} s"
                                      if m.kc is not None else "") + ".",
        *[f"- **Warning:** {d.details[k]}." for k in WARNING_KEYS if d.details.get(k)],
        *[f"- Not tested: {k} ({why})." for k, why in d.details.get("not_tested", {}).items()],
        *_decided_lines(d),
        *_gate_lines(d),
        *_slow_line_lines(d),
        *_range_lines(d),
        *_line_lines(d),
        *_held_lines(d),
        *_rival_lines(d),
        *_residual_lines(d),
        *_detectable_lines(d),
        "",
        "| physics | score (0 = best) | validation NRMSE | improvement | p-value | chosen |",
        "|---|---|---|---|---|---|",
    ]
    for r in d.ranking:
        lines.append(f"| {r['physics']} | {r['score']:.1f} | {r['nrmse_validation']:.3f} | "
                     f"{r['improvement']:.0%} | {r['p_value']:.2g} | "
                     f"{_chosen_mark(d, r['physics'])} |")
    lines += ["", "Figures: `replay.png`, `residual.png`, `spectrum.png`, `phase.png`.", ""]
    return "\n".join(lines)
