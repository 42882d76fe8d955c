"""The published stiction detectors side by side on real loops (Jelali & Huang 2010, ch. 13).

Every method gives ``stiction``, ``no_stiction`` or ``inconclusive`` (with its reason)
per recording window; :func:`loop_verdicts` turns windows into one verdict per physical
loop (majority of the decided windows), :func:`method_rates` scores each method with
Wilson intervals, and :mod:`.consensus` combines them.

Methods (each with its paper's rule and default thresholds; see the estimators):

- ``horch`` — Horch (1999) OP–PV cross-correlation (odd ⇒ stiction); integrating loops
  are out of scope (inconclusive);
- ``he`` — He et al. (2007) triangle vs sine curve fitting of the control error;
- ``area_ratio`` — Singhal & Salsbury (2005);
- ``kano`` — Kano et al. (2004) method A on the OP–MV plot (PV stands for MV in flow
  loops, constant within its own noise floor; otherwise inconclusive: MV not recorded);
- ``yamashita`` — Yamashita (2006) qualitative shapes (same MV rule);
- ``hagglund`` — Hägglund (2011) shape analysis: each half period of the control error
  compared with a square and a sine wave (square ⇒ stiction); flow loops only, elsewhere
  inconclusive (a sticky valve behind a slow process gives no square error);
- ``choudhury`` — Choudhury, Shah & Thornhill (2004, 2006): bicoherence NGI/NLI on the
  control error, then the PV–OP ellipse fit: nonlinear and an ellipse ⇒ stiction;
  non-Gaussian but linear ⇒ no stiction (not a valve nonlinearity); Gaussian ⇒
  inconclusive (at these lengths the test finds no simulated limit cycle non-Gaussian);
- ``hammerstein`` — closed-loop Hammerstein identification (Srinivasan et al. 2005;
  Jelali 2008; Karra & Karim 2009; :mod:`stictionbench.diagnosis.hammerstein`): a
  stick-slip valve with FOPDT process by the prediction-error method; stiction when the
  valve beats the linear loop and the interval of the slip jump J excludes 0;
- ``delay_est_mv`` — the seed paper's CO→MV delay with MV from that fitted valve (OP
  itself when the valve does not beat the linear loop);
  both model-based methods call a valve *not* found inconclusive on data without any
  set-point excitation: there the process identified from OP → PV is biased
  (``experiments/regulatory_bias.py``);
- ``ellipse_v1`` — this project's first-release rule (ellipse axis ratio and residual,
  thresholds chosen after looking at these loops: **in-sample**, shown for reference).

The two model-based methods share one fit (about a second per window).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..estimators import make
from ..op_range import op_range_of
from ..recording import Recording
from .quality import prepare

VERDICTS = ("stiction", "no_stiction", "inconclusive")
#: loop types of plant tags and ISDB descriptions: F flow, L level, P pressure,
#: T temperature, A analyser/concentration/composition, PD differential pressure
TYPE_WORDS = {"flow": "F", "level": "L", "pressure": "P", "temperature": "T",
              "analyser": "A", "analyzer": "A", "concentration": "A", "composition": "A",
              "differential pressure": "PD"}


#: an ISA-5.1 controller tag in a loop's name: the measured variable's letter(s) (PD
#: differential pressure, F flow, L level, P pressure, T temperature, A analysis), then
#: I (indicating) and/or R (recording), then C (controller), then the loop number
TAG_LETTERS = r"(PD|F|L|P|T|A)(?:I|R|IR|RI)?C"
TAG = re.compile(rf"(?<![A-Z]){TAG_LETTERS}(?=[-_.]?\d)")


def tag_type(name: str) -> str:
    """Loop type from an ISA-5.1 controller tag in ``name`` (``2411FIC20102``,
    ``..._LIC63001``, ``PDIC-12``, ``FC445``); ``"?"`` when there is none, or when
    different tags in the name disagree.

    Examples
    --------
    >>> [tag_type(n) for n in ("2411FIC20102", "LYCDU.CDU.7040-312_LIC63001", "PDIC-12",
    ...                        "FC445", "CHEM12", "loop7")]
    ['F', 'L', 'PD', 'F', '?', '?']
    """
    kinds = set(TAG.findall(name.upper()))
    return kinds.pop() if len(kinds) == 1 else "?"


def _type_code(given: str) -> str:
    """A labels table's ``loop_type`` as a code: a code (``F``, ``PD``) as it is, a word
    (``flow``, ``Level``) or a tag's letters (``FIC``) translated, anything else upper-case."""
    given = given.strip()
    if given.lower() in TYPE_WORDS:
        return TYPE_WORDS[given.lower()]
    code = given.upper()
    if code in TYPE_WORDS.values():
        return code
    letters = re.fullmatch(TAG_LETTERS, code)
    return letters.group(1) if letters else code


def loop_type(rec: Recording) -> str:
    """Loop type from the labels (``loop_type``, else the first word of ``desc``), else
    from an ISA-5.1 controller tag in the loop's name (:func:`tag_type`: a folder of
    recordings without a labels table); ``"?"`` when unknown.

    Examples
    --------
    >>> r = Recording.from_arrays(np.arange(200.0), np.zeros(200), np.ones(200),
    ...                           meta={"labels": {"desc": "flow; FC145"}})
    >>> loop_type(r)
    'F'
    >>> loop_type(Recording.from_arrays(np.arange(200.0), np.zeros(200), np.ones(200),
    ...                                 meta={"group": "2111FIC46005"}))
    'F'
    >>> [loop_type(Recording.from_arrays(np.arange(200.0), np.zeros(200), np.ones(200),
    ...                                  meta={"labels": {"loop_type": v}}))
    ...  for v in ("F", "flow", "Level", "FIC", "PD", "pH")]
    ['F', 'F', 'L', 'F', 'PD', 'PH']
    """
    lab = dict(rec.meta.get("labels") or {})
    if lab.get("loop_type"):
        return _type_code(str(lab["loop_type"]))
    word = str(lab.get("desc", "")).split(";")[0].strip().lower()
    if word in TYPE_WORDS:
        return TYPE_WORDS[word]
    return tag_type(str(rec.meta.get("group") or rec.meta.get("name") or ""))


@dataclass(frozen=True)
class Call:
    """One method's verdict on one window."""

    verdict: str
    reason: str
    value: float | None = None
    #: what the verdict rests on, in words, where the method says (e.g. Yamashita's
    #: ``ρ`` with its number of moving samples and interval); empty otherwise
    evidence: str = ""


def _from_result(res) -> Call:
    d = res.diagnostics
    v = d.get("verdict") or {True: "stiction", False: "no_stiction"}.get(res.decision,
                                                                          "inconclusive")
    val = float(res.value) if res.value is not None and math.isfinite(res.value) else None
    return Call(v, str(d.get("reason", "")), val, str(d.get("evidence", "")))


#: where PV stands in for MV (kano, yamashita), count only stuck stretches that end in a
#: slip (the detectors' ``slip_exit``; :mod:`~stictionbench.estimators.slip_exit`). Off:
#: ``experiments/slip_exit.py`` measures it (``reports/real/slip_exit.md``)
SLIP_EXIT = False


def _detector(name: str, params: Callable[[str], dict[str, Any]] | None = None,
              mv_rule: bool = False) -> Callable[[Recording, str], Call]:
    """A registered detector on OP and PV; with ``mv_rule`` on OP and MV, PV standing in
    for an unrecorded MV in a flow loop (the detector is told, ``flow_loop=True``, so
    that it judges PV against PV's own noise, not against a band in OP's units)."""
    def run(rec: Recording, kind: str) -> Call:
        kw = params(kind) if params else {}
        if not mv_rule:
            return _from_result(make(name, **kw).estimate(rec, x="OP", y="PV"))
        if rec.MV is None and kind != "F":
            return Call("inconclusive", "MV not recorded and not a flow loop")
        return _from_result(make(name, flow_loop=kind == "F", slip_exit=SLIP_EXIT, **kw)
                            .estimate(rec, x="OP"))
    return run


def _choudhury(rec: Recording, kind: str) -> Call:
    """Choudhury, Shah & Thornhill: the bicoherence test, then the PV–OP ellipse.

    A Gaussian answer (NGI ≤ 0.001) is *inconclusive*, not "no stiction": the test called
    0 of 96 simulated stick-slip limit cycles non-Gaussian at 751–4096 samples (the
    lengths it uses: at most 4096, K ≤ 63 segments) and 0 of 48 at 16384–32768 samples
    with that cap lifted (``experiments/bicoherence_power.py``,
    ``reports/real/bicoherence_power.md``), so it is no evidence against a sticky valve.
    (The other reading of NGI, the mean over the significant bic² only, calls 88 % of
    those sticky valves and 91 % of the linear loops nonlinear: no better.)
    A non-Gaussian but linear answer (NLI ≤ 0.01) still counts against stiction.
    """
    bic = make("bicoherence").estimate(rec, x="PV")
    d = bic.diagnostics
    if not d.get("non_gaussian"):
        return Call("inconclusive", f"Gaussian (NGI ≤ 0) at K = {d['k_segments']} segments: "
                    "the test has no power there", float(d["ngi"]))
    if not bic.decision:
        return Call("no_stiction", "non-Gaussian but linear (NLI ≤ 0)", float(d["nli"]))
    ell = make("ellipse").estimate(rec, x="OP", y="PV")
    if ell.diagnostics.get("fitted") and ell.value and ell.value > 0:
        return Call("stiction", "nonlinear, PV–OP ellipse", float(ell.value))
    return Call("inconclusive", "nonlinear, no PV–OP ellipse", float(d["nli"]))


def _ellipse_v1(rec: Recording, kind: str) -> Call:
    from .ellipse_rule import StictionRule, assess

    e = assess(rec, str(rec.meta.get("name", "")), StictionRule(), run_diagnosis=False)
    return Call(str(e["verdict"]).replace("unusable", "inconclusive"),
                "first-release ellipse rule (in-sample)", e.get("ellipse_axis_ratio"))


#: the window being judged and its Hammerstein fit (one fit, two methods). The window
#: itself is held, not its ``id``: a freed window's id can be reused by the next one
_FIT: list[Any] = [None, None]


def _hammerstein_fit(rec: Recording):
    from ..diagnosis.hammerstein import fit_hammerstein

    if _FIT[0] is not rec:
        _FIT[:] = [rec, fit_hammerstein(rec)]
    return _FIT[1]


#: set-point excitation (:func:`~stictionbench.diagnosis.process.setpoint_excitation`)
#: below which the data hold no external excitation at all: the set point moves less than
#: a tenth of the control error's standard deviation
NO_EXCITATION = 0.1


def _unexcited(rec: Recording, value: float | None = None) -> Call | None:
    """The model-based methods' premise: an identifiable process. With no external
    excitation at all (a set point that does not move, or none recorded) a valve *not*
    found is no evidence (``experiments/regulatory_bias.py``: 3 of 24 sticky valves found
    on slow regulatory loops, 24 of 24 with set-point steps), so it is inconclusive, as
    "no oscillation" is for the oscillation-based methods; a valve that *is* found stays
    a finding (ideal valves called sticky there with an excitation below the ``diagnose``
    warning's threshold: 0 of 52). Between no excitation and that threshold the verdict
    stands: a first version applied the rule up to that threshold and turned correct
    "no stiction" answers on the set-point-driven simulated loops
    (``reports/real/simulated.md``, servo) into inconclusive ones, raising the
    consensus's false alarms there from 1 to 8 of 24 (so this limit was chosen after
    seeing that check)."""
    from ..diagnosis.process import setpoint_excitation

    x = setpoint_excitation(rec)
    if x >= NO_EXCITATION:
        return None
    return Call("inconclusive", f"regulatory data (set-point excitation {x:.2g}): the "
                                "process cannot be identified well enough to rule a valve "
                                "out", value)


def _hammerstein(rec: Recording, kind: str) -> Call:
    """Closed-loop Hammerstein identification (stick-slip valve + FOPDT, prediction-error
    method): stiction when the valve beats the linear loop and J's interval excludes 0;
    no stiction only on data with set-point excitation (:func:`_unexcited`)."""
    h = _hammerstein_fit(rec)
    if h.stiction:
        # J in per cent of OP's range where it is recognised (an OP in 0–1 too), else in
        # OP's own units; the value stays in OP's units
        span = op_range_of(rec)
        scale, unit = (100.0 / (span[1] - span[0]), " %") if span else (1.0, " in OP's units")
        lo, hi = (scale * v for v in h.J_interval)
        return Call("stiction", f"stick-slip valve, J = {scale * h.J:.2g}{unit} "
                                f"[{lo:.2g}, {hi:.2g}]", h.J)
    if (why := _unexcited(rec, h.J if h.sticky else h.S)) is not None:
        return why
    if h.sticky:
        return Call("no_stiction", "dead band without slip jump (J interval holds 0)", h.J)
    return Call("no_stiction", "no valve nonlinearity beats the linear loop", h.S)


def _delay_estimated_mv(rec: Recording, kind: str) -> Call:
    """The paper's CO→MV delay (``xcorr``) with MV from the fitted Hammerstein valve
    (plants do not record MV); delay > 0.5 samples ⇒ stiction; no stiction only on data
    with set-point excitation (:func:`_unexcited`). A valve that does not beat the linear
    loop (:attr:`~stictionbench.diagnosis.hammerstein.HammersteinResult.sticky` false)
    is not identified: the estimated MV is then OP itself, without lag (a first version
    read the lag off such a valve and called stiction on a simulated ideal-valve loop)."""
    h = _hammerstein_fit(rec)
    if not h.sticky or h.S <= 0 or np.ptp(h.mv) <= 0:
        return _unexcited(rec, 0.0) or Call("no_stiction", "no valve nonlinearity identified: "
                                                      "the estimated MV is OP (no lag)", 0.0)
    est = Recording(t=rec.t, PV=rec.PV, OP=rec.OP, MV=np.asarray(h.mv, float), Ts=rec.Ts,
                    meta=rec.meta)
    c = _from_result(make("xcorr").estimate(est, x="OP", y="MV"))
    if c.reason or c.value is None:
        return c
    if c.verdict != "stiction" and (why := _unexcited(rec, c.value)) is not None:
        return why
    side = "lags" if c.verdict == "stiction" else "does not lag"
    return Call(c.verdict, f"estimated MV {side} OP: delay {c.value:.3g} samples", c.value)


#: name -> function(recording, loop type) -> Call; in the order of the report
METHODS: dict[str, Callable[[Recording, str], Call]] = {
    "horch": _detector("horch", lambda k: {"integrating": k == "L"}),
    "he": _detector("he", lambda k: {"integrating": k == "L"}),
    "area_ratio": _detector("area_ratio"),
    "kano": _detector("kano", mv_rule=True),
    "yamashita": _detector("yamashita", mv_rule=True),
    "hagglund": _detector("hagglund", lambda k: {"flow_loop": k == "F"}),
    "choudhury": _choudhury,
    "hammerstein": _hammerstein,
    "delay_est_mv": _delay_estimated_mv,
    "ellipse_v1": _ellipse_v1,
}
#: methods whose thresholds were not set on the shared real loops
PUBLISHED = ("horch", "he", "area_ratio", "kano", "yamashita", "hagglund", "choudhury",
             "hammerstein", "delay_est_mv")
#: methods that fit a model (about a second per window): compared, and in the consensus
#: only when batch can afford them (see :data:`FAST`)
FAST = ("horch", "he", "area_ratio", "kano", "yamashita", "hagglund", "choudhury")


def window_calls(rec: Recording, name: str,
                 methods: Iterable[str] = tuple(METHODS)) -> dict[str, Any]:
    """Every method's call on one window, after the data-quality screen (held samples
    of a compressed record treated as missing: :func:`.quality.prepare`).

    Returns ``{"name", "group", "label", "loop_type", "quality", "<method>": Call...}``;
    an unusable window gets ``unusable`` from every method, with the screen's reason.
    """
    kind = loop_type(rec)
    rec, q, released = prepare(rec)
    out: dict[str, Any] = {"name": name, "group": str(rec.meta.get("group", name)),
                           "label": rec.meta.get("label"), "loop_type": kind,
                           "quality": q.summary(), "quality_score": q.flags.get("score"),
                           "holds_released": released}
    for m in methods:
        if not q.usable:
            out[m] = Call("unusable", q.summary())
            continue
        try:
            out[m] = METHODS[m](rec, kind)
        except Exception as exc:  # one method failing on odd data must not stop the rest
            out[m] = Call("inconclusive", failure_reason(exc, rec))
    return out


def failure_reason(exc: BaseException, rec: Recording, limit: int = 120) -> str:
    """A method's error as a verdict's reason: one line, without the ``source: `` prefix
    an input error names the file by (the window is the entry's name already), cut at a
    word with "…" beyond ``limit`` characters (a first version cut at 80 characters
    mid-word and kept the relative path: "../shared/data/plant/….csv: 126 samples;
    valve id").

    Examples
    --------
    >>> from stictionbench.recording import Recording
    >>> import numpy as np
    >>> r = Recording(np.arange(5.0), np.zeros(5), np.zeros(5), meta={"source": "a/b.csv"})
    >>> failure_reason(ValueError("a/b.csv: 126 samples; valve identification needs >= 200"), r)
    '126 samples; valve identification needs >= 200'
    >>> failure_reason(ValueError("x " * 100), r, limit=20)
    'x x x x x x x x x x…'
    """
    text = " ".join(str(exc).split()) or type(exc).__name__
    src = str(rec.meta.get("source", ""))
    if src and text.startswith(src + ": "):
        text = text[len(src) + 2:]
    if len(text) > limit:
        text = text[:limit].rsplit(" ", 1)[0].rstrip(" ;,:") + "…"
    return text


def as_call(c: Call | dict[str, Any]) -> Call:
    return c if isinstance(c, Call) else Call(str(c["verdict"]), str(c.get("reason", "")),
                                             c.get("value"), str(c.get("evidence", "")))
